"""simcap: the default captioner, a small CNN + GRU trained on the project's own renders."""
