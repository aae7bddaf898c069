"""The transfer task: a planar arm pushes a cube through a gap between two walls (the scene, the evaluator, the demonstrations)."""
