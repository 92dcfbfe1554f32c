"""gloverec MuJoCo robot-hand environments (Gymnasium). Robots, tasks and the scripted demonstrator land
here with the environments issue; the package exists now so the layout the user asked for is in place."""
