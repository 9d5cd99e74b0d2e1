"""Helpers shared by the tests: problems, tables, CLI and C drivers."""
