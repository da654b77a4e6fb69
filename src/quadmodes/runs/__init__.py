"""Runs of a case: reduced model from the cache, chunked integration, validity, Kane spin-up,
and the results dataset."""
