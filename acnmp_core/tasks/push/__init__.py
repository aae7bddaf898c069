"""The push task: a planar arm pushes a cylinder (the evaluator, the settings, the expert demonstrations)."""
