"""The mutation check of the learner (run.py) and its table of mutants (mutants.py)."""
