"""Live views of a glove driving a robot hand: what `gloverec view` shows (MuJoCo's viewer or a video)."""
