"""`gloverec calibrate`: the calibration procedure on a glove, saved per glove id (docs/fusion.md)."""
