"""The range of a seed: every random choice is seeded by a NumPy seed, an unsigned 32-bit word."""

SEED_MAX = 2**32 - 1
