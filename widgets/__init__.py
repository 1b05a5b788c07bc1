"""Interactive placement widgets and Qt panels (installed as ``wrinkle_vis.widgets``)."""
