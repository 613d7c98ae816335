"""One module per `stereotrack` sub-command (see cli.py for the contract)."""
