"""One keyword, one meaning, across every method: light samples are ``samples=``, the meshes that
cast are ``casters=``, and which faces of closed meshes cast is ``caster_faces=``."""

import inspect

import numpy as np
import pytest

import softshadows as ss
from softshadows.methods import METHODS, SAMPLED


def keywords(name):
    return set(inspect.signature(METHODS[name]).parameters)


@pytest.mark.parametrize("name", list(METHODS))
def test_light_samples_go_in_as_samples_and_nothing_else(name):
    params = keywords(name)
    assert ("samples" in params) == (name in SAMPLED)
    assert "views" not in params


@pytest.mark.parametrize("name", list(METHODS))
def test_every_method_documents_casters_as_meshes(name):
    assert "casters" in keywords(name)
    assert "casters : sequence of int or str, optional" in METHODS[name].__doc__


def test_which_faces_of_closed_meshes_cast_is_caster_faces():
    for name in METHODS:
        assert ("caster_faces" in keywords(name)) == (name in ("ray_traced", "alias_free")), name


@pytest.fixture(scope="module")
def columns():
    setup = ss.scenes.get("columns", width=32, height=32)
    gb = ss.gbuffer(setup.scene, setup.camera)
    ground = gb.mask & (gb.face_ids < len(setup.scene.meshes[0].faces))
    return setup, gb, ground


@pytest.mark.parametrize("name", list(METHODS))
def test_casters_leave_out_the_meshes_that_do_not_cast(name, columns):
    """The columns shadow the ground; with only the ground casting (by name, or by index),
    nothing shadows it."""
    setup, gb, ground = columns
    options = {"samples": setup.light.samples(16)} if name in SAMPLED else {}
    if name in ("shadow_map", "pcss", "cssm", "backprojection", "mvr", "vwss"):
        options["resolution"] = 256
    shadowed = METHODS[name](setup.scene, setup.light, gb, **options)
    assert np.mean(shadowed[ground] < 0.5) > 0.02, "the columns must shadow the ground"
    for casters in (["ground"], [0]):
        alone = METHODS[name](setup.scene, setup.light, gb, casters=casters, **options)
        assert np.mean(alone[ground]) > 0.99 and not np.any(alone[ground] < 0.5), casters
