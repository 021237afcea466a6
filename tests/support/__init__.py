"""What the tests share: helpers, harnesses and fixtures. A test module imports the package it tests, these modules
and nothing else of tests/ (tests/foundation/test_test_imports.py checks it); the fixtures defined here reach the
tests through tests/conftest.py's pytest_plugins, never through an import. See docs/testing.md."""
