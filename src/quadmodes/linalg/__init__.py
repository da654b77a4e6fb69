"""Sparse linear algebra behind one small interface: factor once, solve many."""
