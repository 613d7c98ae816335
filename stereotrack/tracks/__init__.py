"""Tracks: identities over time (a Kalman filter per ball, gated global assignment, a lifecycle in seconds)."""

from .manager import COASTING, CONFIRMED, TENTATIVE, TrackManager, in_free_flight, motion_model

__all__ = ["COASTING", "CONFIRMED", "TENTATIVE", "TrackManager", "in_free_flight", "motion_model"]
