"""Network curves: activations, the torch and numpy networks, skorch, L-BFGS, torch shooting."""
