"""Helpers shared by test modules of several directories (a test module imports these, conftest.py and the package
under test, never another test module)."""
