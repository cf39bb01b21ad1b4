"""Pictures: sample scatter plots lie in the light's plane; grids fit a notebook and leave pyplot alone."""

import subprocess
import sys

import numpy as np
import pytest

import softshadows as ss


def test_show_samples_projects_onto_the_light_plane():
    light = ss.RectLight((0, 5, 0), (2, 0, 0), (0, 0, 0.5))
    samples = light.samples(64, pattern="stratified", seed=1)
    ax = ss.plot.show_samples(light, samples)
    xy = ax.collections[0].get_offsets()
    assert xy.shape == (64, 2)
    # The plane's principal axes: spread 2 along u, 0.5 along v (in some order and sign).
    spans = sorted(np.ptp(np.asarray(xy), axis=0))
    assert spans[1] > 3.5 and 0.8 < spans[0] < 1.0


def _visibility(n: int):
    """A reference gradient and n results, each a little brighter."""
    reference = np.tile(np.linspace(0, 1, 24), (16, 1))
    return reference, {f"method {k}": np.clip(reference + 0.01 * k, 0, 1) for k in range(n)}


def test_plotting_leaves_the_users_backend_alone():
    # In a fresh interpreter: the backend is process-wide, and "svg" stands in for Qt, Tk or ipympl.
    code = (
        "import matplotlib; matplotlib.use('svg'); import numpy as np; import softshadows as ss; "
        "ss.plot.comparison_grid(np.zeros((4, 4)), {'a': np.ones((4, 4))}); "
        "ss.plot.show_samples(ss.PointLight((0, 1, 0)), np.zeros((3, 3))); "
        "print(matplotlib.get_backend())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "svg"


def test_figures_are_not_left_registered_with_pyplot(tmp_path):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    reference, results = _visibility(2)
    fig = ss.plot.comparison_grid(reference, results)
    saved = ss.plot.comparison_grid(reference, results, path=tmp_path / "grid.png")
    ax = ss.plot.show_samples(ss.PointLight((0, 1, 0)), np.zeros((3, 3)))
    assert plt.get_fignums() == before
    assert fig.canvas.manager is None and saved.canvas.manager is None and ax.figure.canvas.manager is None
    assert (tmp_path / "grid.png").read_bytes().startswith(b"\x89PNG")


def test_a_grid_of_twelve_methods_wraps_to_a_notebook_width():
    reference, results = _visibility(12)
    fig = ss.plot.comparison_grid(reference, results)
    width, height = fig.get_size_inches()
    assert width <= ss.plot.MAX_WIDTH and width < height  # was 13 x 2.6 = 33.8 in wide, 5.6 in tall
    assert len(fig.axes) == 26  # a visibility and an error panel for the reference and each method
    tops = fig.axes[::2]
    assert [ax.get_title() for ax in tops] == ["reference", *results]
    columns = {round(ax.get_position().x0, 3) for ax in tops}
    rows = {round(ax.get_position().y0, 3) for ax in tops}
    assert len(columns) <= ss.plot.MAX_COLUMNS and len(rows) == 3


def test_a_grid_draws_into_a_pyplot_figure_to_show():
    import matplotlib.pyplot as plt

    fig = plt.figure()
    try:
        reference, results = _visibility(1)
        assert ss.plot.comparison_grid(reference, results, figure=fig) is fig
        assert len(fig.axes) == 4 and plt.fignum_exists(fig.number)
    finally:
        plt.close(fig)
    with pytest.raises(ValueError, match="figure: expected a matplotlib.figure.Figure"):
        ss.plot.comparison_grid(reference, results, figure="new")


def test_the_setup_preview_shows_the_light_and_says_what_is_wrong():
    setup = ss.scenes.get("columns", width=64, height=64)
    ax = ss.plot.setup(setup, size=48)
    assert ax.get_title().endswith("facing the scene, 1 light frustum") and ax.figure.canvas.manager is None
    # The light lies above the view: the canvas grows to hold it, and its star is drawn there.
    (x, y), = setup.camera.with_size(48, 48).project([setup.light.center]) - 0.5
    top, bottom = ax.get_ylim()[1], ax.get_ylim()[0]
    assert top <= y < -0.5 and top < bottom
    assert any(line.get_marker() == "*" and np.allclose(line.get_xydata(), [[x, y]]) for line in ax.get_lines())
    away = setup.with_light(ss.RectLight((0, 3, 0), (0.5, 0, 0), (0, 0, -0.5)))
    assert ss.plot.setup(away, size=32).get_title().endswith("faces away from every receiver, 1 light frustum")
    mirror = np.array([1.0, -1.0, 1.0])
    below = setup.with_light(ss.RectLight(setup.light.center * mirror, setup.light.u * mirror, -setup.light.v * mirror))
    assert ss.plot.setup(below, size=32).get_title().endswith("its centre hidden from every receiver, 1 light frustum")


def test_the_setup_preview_draws_a_frustum_per_cube_face_around_a_lamp_in_a_room():
    from test_lights_among_geometry import LAMP, LIGHTS, room

    camera = ss.Camera.look_at((1.9, 1.8, 1.9), (0, 0, 0), (0, 1, 0), 100.0, 48, 48)
    lamp = ss.scenes.Setup("room", room(), LIGHTS["sphere"], camera, "a lamp in a room", has_ground=False)
    ax = ss.plot.setup(lamp, size=48)
    frusta = int(ax.get_title().split(", ")[-1].split()[0])
    assert 1 < frusta <= 6
    # Each frustum: four edges from the lamp and four around its far plane, 64 points each.
    edges = [line for line in ax.get_lines() if line.get_color() == "deepskyblue"]
    assert len(edges) == 8 * frusta
    drawn = np.concatenate([line.get_xydata() for line in edges[::8]])
    (x, y), = camera.project([LAMP]) - 0.5
    assert np.allclose(drawn[::64], [x, y])  # every first edge starts at the lamp


def test_project_inverts_the_gbuffers_rays():
    setup = ss.scenes.get("torus_knot", width=40, height=30)
    gb = ss.gbuffer(setup.scene, setup.camera)
    rows, cols = np.nonzero(gb.mask)
    xy = setup.camera.project(gb.positions[rows, cols])
    np.testing.assert_allclose(xy, np.stack([cols + 0.5, rows + 0.5], axis=1), atol=2e-3)
