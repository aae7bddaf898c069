"""The baselines the experiments compare ACNMP with.

- :mod:`.promp`: Probabilistic Movement Primitives (Paraschos et al. 2013), conditioning included.
- :mod:`.promp_rl`: a ProMP adapted by episodic RL (REPS or reward-weighted regression; Stark et
  al. 2019's adaptive ProMP).
- :mod:`.promp_selfimprove`: ProMP self-improvement across environments (a Gaussian process over
  task parameters and policy search, after Ewerton et al. 2019).
"""
