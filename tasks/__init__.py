"""Prefect tasks: thin, cached wrappers around the pure functions of nlupdate."""
