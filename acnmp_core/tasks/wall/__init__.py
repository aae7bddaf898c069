"""The wall task: a 2-D point passes a gap in a wall (the evaluator, the settings)."""
