"""fitting: the fit as a problem (FitProblem, from the one table of its settings), solved into a
FitResult, and ErrorModelCV, the estimator that solves it in its ``fit``."""
