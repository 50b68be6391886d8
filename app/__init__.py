"""The application layer: executor, mission service, viewer and command-line interface."""
