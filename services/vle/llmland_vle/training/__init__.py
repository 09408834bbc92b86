"""``llmland-vle train``: regenerate simcap's data from seeded worlds, train, evaluate.

Imports the simulator (``llmland_sim``) lazily; the run-time service never imports this.
"""
