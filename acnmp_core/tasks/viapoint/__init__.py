"""The via-point task: 1-D trajectories through a via-point (the evaluator and the demonstrations)."""
