"""The UR10 pick-and-place task: the evaluator (reward, success) and the expert demonstrations."""
