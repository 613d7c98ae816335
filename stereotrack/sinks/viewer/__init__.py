"""The rerun viewer sink, split by concern; rerun itself is imported only when a sink is made.

- ``sink.py``: ``RerunSink``, its settings and outputs.
- ``columns.py``: per-frame data gathered for the column batches, and how a batch is sent.
- ``style.py``: colours per target, the default blueprint.
- ``process.py``: viewer processes, ports and URLs.
- ``flags.py``: the command-line flags and the sink they ask for.
"""

from .columns import ColumnWriter, Pending, SeriesBuffer, Trail
from .flags import add_viz_arguments, make_viz_sink, viz_settings_from_args
from .process import normalise_connect_url, rerun_executable
from .sink import BATCH, BATCH_SECONDS, FILE_BATCH, FILE_BATCH_SECONDS, QUEUE, RerunSink, VizOutputs, VizSettings
from .style import (
    ABDUCTIVE,
    APPLICATION_ID,
    PALETTE,
    PALETTE_RGBA,
    PARTICLE_RGBA,
    SEQUENTIAL,
    UNCLUSTERED,
    TargetStyle,
    default_blueprint,
    packed_rgba,
    quaternions_xyzw,
    target_colour,
    with_alpha,
)

__all__ = [
    "ABDUCTIVE", "APPLICATION_ID", "BATCH", "BATCH_SECONDS", "FILE_BATCH", "FILE_BATCH_SECONDS", "PALETTE", "PALETTE_RGBA",
    "PARTICLE_RGBA", "QUEUE", "SEQUENTIAL", "UNCLUSTERED", "ColumnWriter", "Pending", "TargetStyle", "RerunSink", "SeriesBuffer", "Trail", "VizOutputs",
    "VizSettings", "add_viz_arguments", "default_blueprint", "make_viz_sink", "normalise_connect_url", "packed_rgba",
    "quaternions_xyzw", "rerun_executable", "target_colour", "viz_settings_from_args", "with_alpha",
]  # fmt: skip
