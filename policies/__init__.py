"""gloverec behaviour-cloning policies (LeRobot plugins). They land here with the behaviour-cloning issue;
the package exists now so the layout the user asked for is in place."""
