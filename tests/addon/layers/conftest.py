"""The layering tests' shared scene: the two-tube figure (a body, a shirt, a jacket crossing it)."""

import importlib

import pytest


@pytest.fixture
def tubes(extension, clean_scene):
    return importlib.import_module(f"{extension.__name__}.sample_scenes.tubes").build(seed=0, resolution=48)
