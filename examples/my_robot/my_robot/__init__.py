"""A robot plugin for ACNMP: a 2-link planar arm reaching a goal, as a Gymnasium environment."""
