"""One-step regressors (LR, LWPR, GPR, SoR, LGPR) and their persistence."""
