"""Shim for colcon, whose ament_python build runs setup.py; everything is declared in pyproject.toml."""

from setuptools import setup

setup()
