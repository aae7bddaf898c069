"""The pouring task: the evaluator (grams poured against the target) and the expert demonstrations."""
