"""LLM-Land command-line front end: launch services, run episodes, experiments, benchmarks."""
