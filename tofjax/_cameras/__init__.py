"""One module per camera preset (:mod:`tofjax._presets`): its ``PRESET``."""
