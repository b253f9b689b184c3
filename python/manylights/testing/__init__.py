"""Mitsuba 3 references of the same scene XML, for tests and benchmarks (``mitsuba``; Mitsuba is imported lazily)."""
