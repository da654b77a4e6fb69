"""Runs of a case: the reduced model from :mod:`quadmodes.models`, chunked integration,
validity, Kane spin-up, and the results dataset."""
