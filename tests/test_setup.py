"""Two commands, really: scripts/demo.sh and scripts/test.sh set a fresh Debian/Ubuntu machine up
(scripts/_setup.sh), the core installs without the evaluation stack, and a missing extra or a
missing LLVM says what to install.

The scripts run here in a subprocess whose PATH holds only fakes of the system's tools (dpkg,
apt-get, sudo, id, cargo, ...), which record their calls: nothing is installed or built.
"""

import os
import shutil
import subprocess
import sys
import textwrap
import types
import warnings
from pathlib import Path

import pytest

from softshadows import reference
from softshadows._extras import MissingExtraError, require

ROOT = Path(__file__).resolve().parent.parent
SCRIPTS = ROOT / "scripts"
BASH = shutil.which("bash")
RUSTUP = "curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y"
#: The evaluation extra's modules (pyproject.toml), and pymeshlab of the models extra.
EVALUATION_MODULES = ("mitsuba", "drjit", "pandas", "matplotlib", "skimage", "flip_evaluator", "OpenEXR", "jinja2")

pytestmark = pytest.mark.skipif(BASH is None or sys.platform == "win32", reason="scripts/demo.sh and scripts/test.sh are bash scripts for Debian/Ubuntu; no bash on this machine")


# ----------------------------------------------------------------------------- fake machine


FAKES = {
    # dpkg -s PKG: installed when listed in $FAKE_DIR/installed.
    "dpkg": """
        echo "dpkg $*" >> "$FAKE_DIR/log"
        if [ "$1" = -s ] && grep -qx "$2" "$FAKE_DIR/installed"; then
          printf 'Package: %s\\nStatus: install ok installed\\n' "$2"; exit 0
        fi
        echo "dpkg-query: package '$2' is not installed" >&2; exit 1
    """,
    # apt-get install PKG...: records them as installed, unless FAKE_APT_STATUS says it fails.
    "apt-get": """
        echo "apt-get $*" >> "$FAKE_DIR/log"
        [ "${FAKE_APT_STATUS:-0}" = 0 ] || exit "$FAKE_APT_STATUS"
        if [ "$1" = install ]; then
          for p in "$@"; do case "$p" in -*|install) ;; *) echo "$p" >> "$FAKE_DIR/installed" ;; esac; done
        fi
    """,
    "id": """
        if [ "$1" = -u ]; then echo "$FAKE_UID"; else echo "uid=$FAKE_UID"; fi
    """,
    # Passwordless sudo when FAKE_SUDO=ok, else sudo -n fails as it does when it needs a password.
    "sudo": """
        echo "sudo $*" >> "$FAKE_DIR/log"
        [ "$FAKE_SUDO" = ok ] || { echo "sudo: a password is required" >&2; exit 1; }
        [ "$1" = -n ] && shift
        exec "$@"
    """,
    # The build: test.sh stops at its first cargo call, after the set-up.
    "cargo": """
        echo "cargo $*" >> "$FAKE_DIR/log"; exit 3
    """,
    "rustc": "exit 0",
    "cc": "exit 0",
    "curl": "exit 0",
    # python3 -c (the set-up's checks) runs; anything else (pip, venv) is recorded and refused.
    "python3": f"""
        [ "$1" = -c ] && exec '{sys.executable}' "$@"
        echo "python3 $*" >> "$FAKE_DIR/log"; exit 6
    """,
}
#: Real tools the scripts and the fakes call.
TOOLS = ("dirname", "basename", "env", "grep", "cat", "true")


class Machine:
    """A fake Debian machine: a bin folder of fakes, the installed packages, a log of calls."""

    def __init__(self, tmp_path, *, installed=(), uid=1000, sudo=False, without=()):
        self.dir = tmp_path / "machine"
        self.bin = self.dir / "bin"
        self.home = self.dir / "home"
        self.bin.mkdir(parents=True)
        self.home.mkdir()
        (self.dir / "installed").write_text("".join(f"{p}\n" for p in installed))
        (self.dir / "log").write_text("")
        for name, body in FAKES.items():
            if name not in without:
                self.fake(name, body)
        for name in TOOLS:
            real = shutil.which(name)
            assert real is not None, name
            (self.bin / name).symlink_to(real)
        self.env = {"PATH": str(self.bin), "HOME": str(self.home), "FAKE_DIR": str(self.dir),
                    "FAKE_UID": str(uid), "FAKE_SUDO": "ok" if sudo else "no", "LC_ALL": "C"}
        if "sudo" in without:
            self.env["FAKE_SUDO"] = "missing"

    def fake(self, name, body, folder=None):
        path = (folder or self.bin) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("#!/bin/sh\n" + textwrap.dedent(body).strip() + "\n")
        path.chmod(0o755)
        return path

    def run(self, script, *args, **env):
        return subprocess.run([BASH, str(SCRIPTS / script), *args], env={**self.env, **env}, cwd=self.dir,
                              capture_output=True, text=True, timeout=120)

    @property
    def log(self) -> list:
        return (self.dir / "log").read_text().splitlines()

    def calls(self, program) -> list:
        return [line for line in self.log if line.split(" ", 1)[0] == program]


def _command_lines(stderr) -> list:
    """The indented lines of a stop message: the commands to run."""
    return [line.strip() for line in stderr.splitlines() if line.startswith("    ")]


# ----------------------------------------------------------------------------- scripts/test.sh


def test_test_sh_without_root_stops_at_once_with_the_one_apt_command(tmp_path):
    machine = Machine(tmp_path, installed=["libllvm19"], uid=1000, sudo=False)
    done = machine.run("test.sh")
    assert done.returncode == 1, done.stderr
    # Only the missing package, in the one command to run, before anything is built.
    assert _command_lines(done.stderr) == ["sudo apt-get install -y mesa-vulkan-drivers"]
    assert "then run scripts/test.sh again" in done.stderr
    assert not machine.calls("apt-get") and not machine.calls("cargo")
    assert "sudo -n true" in machine.log  # it asked sudo without a password, once, and gave up


def test_test_sh_installs_only_the_missing_packages_with_passwordless_sudo(tmp_path):
    machine = Machine(tmp_path, installed=["libllvm19"], uid=1000, sudo=True)
    done = machine.run("test.sh")
    assert done.returncode == 3, done.stderr  # the fake cargo: the set-up is done, the build starts
    installs = [c for c in machine.calls("apt-get") if c.startswith("apt-get install")]
    assert installs == ["apt-get install -y -qq --no-install-recommends mesa-vulkan-drivers"]
    assert "sudo -n env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends mesa-vulkan-drivers" in machine.log
    assert machine.calls("cargo") == ["cargo test -q --release -p softshadows-core"]


def test_test_sh_as_root_installs_with_apt_get_directly(tmp_path):
    machine = Machine(tmp_path, installed=[], uid=0, without=("sudo",))
    done = machine.run("test.sh")
    assert done.returncode == 3, done.stderr
    assert machine.calls("apt-get") == ["apt-get update -qq",
                                        "apt-get install -y -qq --no-install-recommends libllvm19 mesa-vulkan-drivers"]
    assert not machine.calls("sudo")


def test_test_sh_installs_nothing_when_nothing_is_missing(tmp_path):
    machine = Machine(tmp_path, installed=["libllvm19", "mesa-vulkan-drivers"], uid=0)
    done = machine.run("test.sh")
    assert done.returncode == 3, done.stderr
    assert not machine.calls("apt-get") and not machine.calls("sudo")
    assert {"dpkg -s libllvm19", "dpkg -s mesa-vulkan-drivers"} <= set(machine.log)


def test_softshadows_no_install_stops_even_root_with_the_command_without_sudo(tmp_path):
    machine = Machine(tmp_path, installed=[], uid=0)
    done = machine.run("test.sh", SOFTSHADOWS_NO_INSTALL="1")
    assert done.returncode == 1, done.stderr
    assert _command_lines(done.stderr) == ["apt-get install -y libllvm19 mesa-vulkan-drivers"]
    assert not machine.calls("apt-get")


def test_a_failed_apt_get_stops_the_script(tmp_path):
    machine = Machine(tmp_path, installed=[], uid=0)
    done = machine.run("test.sh", FAKE_APT_STATUS="100")
    assert done.returncode == 1
    assert "apt-get could not install libllvm19 mesa-vulkan-drivers" in done.stderr
    assert not machine.calls("cargo")


def test_a_missing_rust_toolchain_is_found_before_anything_else_with_the_rustup_line(tmp_path):
    machine = Machine(tmp_path, installed=["libllvm19", "mesa-vulkan-drivers"], uid=1000, without=("cargo", "rustc"))
    done = machine.run("test.sh")
    assert done.returncode == 1, done.stderr
    assert _command_lines(done.stderr) == [RUSTUP]
    assert "Rust toolchain (cargo and rustc)" in done.stderr


def test_without_rust_nor_curl_nor_root_both_commands_come_at_once(tmp_path):
    machine = Machine(tmp_path, installed=["libllvm19"], uid=1000, without=("cargo", "rustc", "curl"))
    done = machine.run("test.sh")
    assert done.returncode == 1, done.stderr
    assert _command_lines(done.stderr) == ["sudo apt-get install -y mesa-vulkan-drivers curl", RUSTUP]


def test_rust_in_rustups_folder_is_found_off_the_path(tmp_path):
    # Right after the rustup line, in the same shell: ~/.cargo/bin is not on PATH yet.
    machine = Machine(tmp_path, installed=["libllvm19", "mesa-vulkan-drivers"], uid=0, without=("cargo", "rustc"))
    cargo_bin = machine.home / ".cargo" / "bin"
    machine.fake("cargo", FAKES["cargo"], cargo_bin)
    machine.fake("rustc", "exit 0", cargo_bin)
    done = machine.run("test.sh")
    assert done.returncode == 3, done.stderr
    assert machine.calls("cargo") == ["cargo test -q --release -p softshadows-core"]


def test_a_missing_linker_and_venv_module_are_added_to_the_packages(tmp_path):
    # A bare Debian: no cc for rustc to link with, a python3 without ensurepip (python3-venv).
    machine = Machine(tmp_path, installed=["libllvm19", "mesa-vulkan-drivers"], uid=1000, without=("cc", "python3"))
    machine.fake("python3", f"""
        case "$*" in *ensurepip*) exit 1 ;; esac
        [ "$1" = -c ] && exec '{sys.executable}' "$@"
        exit 6
    """)
    done = machine.run("test.sh")
    assert done.returncode == 1, done.stderr
    assert _command_lines(done.stderr) == ["sudo apt-get install -y build-essential python3-venv"]


# ----------------------------------------------------------------------------- scripts/demo.sh


def _demo_venv(machine):
    """A ready .venv-demo whose python records the call and stops the demo (status 5)."""
    venv = machine.dir / "venv-demo"
    machine.fake("python", 'echo "venv-python $*" >> "$FAKE_DIR/log"; exit 5', venv / "bin")
    return venv


def test_demo_sh_without_root_goes_on_without_llvm_with_a_note(tmp_path):
    machine = Machine(tmp_path, installed=[], uid=1000, sudo=False)
    done = machine.run("demo.sh", SOFTSHADOWS_DEMO_VENV=str(_demo_venv(machine)))
    assert done.returncode == 5, done.stderr  # it went on to install softshadows
    assert "scalar_rgb" in done.stderr and "sudo apt-get install -y libllvm19" in done.stderr
    assert not machine.calls("apt-get")
    assert machine.calls("venv-python") == ['venv-python -m pip install -q --disable-pip-version-check .[evaluation,models]']


def test_demo_sh_installs_llvm_when_it_may(tmp_path):
    machine = Machine(tmp_path, installed=[], uid=1000, sudo=True)
    done = machine.run("demo.sh", SOFTSHADOWS_DEMO_VENV=str(_demo_venv(machine)))
    assert done.returncode == 5, done.stderr
    assert "apt-get install -y -qq --no-install-recommends libllvm19" in machine.log
    assert "scalar_rgb" not in done.stderr


def test_demo_sh_stops_without_rust(tmp_path):
    machine = Machine(tmp_path, installed=["libllvm19"], uid=1000, without=("cargo", "rustc"))
    done = machine.run("demo.sh", SOFTSHADOWS_DEMO_VENV=str(_demo_venv(machine)))
    assert done.returncode == 1, done.stderr
    assert _command_lines(done.stderr) == [RUSTUP] and not machine.calls("venv-python")


def test_the_scripts_parse():
    for script in ("_setup.sh", "demo.sh", "test.sh"):
        subprocess.run([BASH, "-n", str(SCRIPTS / script)], check=True)


# ----------------------------------------------------------------------------- lean install


BLOCKED = """
import sys
for name in {modules!r}:
    sys.modules[name] = None  # import name -> ModuleNotFoundError, as when it is not installed
"""


def test_the_core_works_without_the_evaluation_extra(tmp_path):
    code = BLOCKED.format(modules=(*EVALUATION_MODULES, "pymeshlab")) + textwrap.dedent("""
        import numpy as np
        import softshadows as ss
        from softshadows import cli, evaluation, io, metrics, plot, reference

        setup = ss.scenes.get("columns", width=24, height=24)
        gb = ss.gbuffer(setup.scene, setup.camera)
        vis = ss.ray_traced(setup.scene, setup.light, gb, samples=8)
        hard = ss.shadow_map(setup.scene, setup.light, gb)
        assert vis.shape == (24, 24) and 0 < vis[gb.mask].mean() < 1
        print("rmse", metrics.rmse(hard, vis, gb.mask))
        third_party = {m.split(".")[0] for m, mod in sys.modules.items() if mod is not None} - set(sys.stdlib_module_names)
        print("imported", " ".join(sorted(m for m in third_party if not m.startswith("_"))))

        calls = {
            "ssim": lambda: metrics.ssim(hard, vis),
            "flip": lambda: metrics.flip(hard, vis),
            "summary": lambda: metrics.summary(hard, vis, gb.mask),
            "mitsuba_visibility": lambda: reference.mitsuba_visibility(setup.scene, setup.light, gb, 4),
            "evaluate": lambda: ss.evaluate(["columns"], ["ray_traced"], size=16),
            "comparison_grid": lambda: plot.comparison_grid(vis, {"hard": hard}),
            "write_exr": lambda: io.write_exr("v.exr", vis),
            "write_png": lambda: io.write_png("v.png", vis),
        }
        for name, call in calls.items():
            try:
                call()
            except ModuleNotFoundError as exc:
                print(name, "->", exc)
            else:
                print(name, "-> no error")
        print("demo_status", cli.main(["demo", "--out", "demo", "--size", "16"]))
        print("demo_folder", __import__("os").path.exists("demo"))
    """)
    env = {**os.environ, "SOFTSHADOWS_CACHE": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines())
    needs = {"ssim": "softshadows.metrics.ssim needs scikit-image", "flip": "softshadows.metrics.flip needs flip-evaluator",
             "summary": "softshadows.metrics.ssim needs scikit-image",
             "mitsuba_visibility": "softshadows.reference needs mitsuba", "evaluate": "softshadows.evaluate needs pandas",
             "comparison_grid": "softshadows.plot.comparison_grid needs matplotlib",
             "write_exr": "softshadows.io.write_exr needs openexr", "write_png": "softshadows.io.write_png needs matplotlib"}
    for name, message in needs.items():
        assert lines[name] == f"-> {message}: pip install 'softshadows[evaluation]'", name
    assert lines["demo_status"] == "1" and lines["demo_folder"] == "False"
    assert "softshadows demo needs mitsuba: pip install 'softshadows[evaluation]'" in done.stderr
    assert "Traceback" not in done.stderr
    # import softshadows, a scene, a G-buffer and two methods need no third-party package but the core's.
    imported = set(lines["imported"].split())
    assert {"numpy", "softshadows"} <= imported <= {"numpy", "softshadows", "tqdm", "trimesh"}, imported


def test_the_core_dependencies_are_lean_and_the_extras_hold_the_rest():
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]

    def names(requirements):
        return {r.split(";")[0].split("[")[0].split(">")[0].split("=")[0].split("<")[0].strip().lower() for r in requirements}

    assert names(project["dependencies"]) == {"numpy", "trimesh", "tqdm"}
    extras = project["optional-dependencies"]
    assert names(extras["evaluation"]) == {"mitsuba", "pandas", "matplotlib", "scikit-image", "flip-evaluator",
                                           "openexr", "jinja2"}
    for extra in ("test", "notebooks"):  # the suite and the notebooks measure: they need the evaluation stack
        assert "softshadows[evaluation,models]" in extras[extra], extra


def test_require_names_the_extra_and_leaves_other_import_errors_alone(tmp_path, monkeypatch):
    with pytest.raises(MissingExtraError, match=r"^softshadows\.x needs no_such_package: pip install 'softshadows\[models\]'$") as info:
        require("no_such_package.sub", extra="models", for_="softshadows.x")
    assert isinstance(info.value, ModuleNotFoundError) and info.value.extra == "models" and info.value.name == "no_such_package"
    # Named by its distribution, also when blocked (None in sys.modules) after an earlier import.
    monkeypatch.setitem(sys.modules, "skimage.metrics", None)
    with pytest.raises(MissingExtraError, match=r"^softshadows\.x needs scikit-image: pip install 'softshadows\[evaluation\]'$"):
        require("skimage.metrics", extra="evaluation", for_="softshadows.x")
    # An installed package whose own dependency is missing is not "install the extra".
    (tmp_path / "half_installed.py").write_text("import no_such_dependency_of_it\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ModuleNotFoundError) as info:
        require("half_installed", extra="evaluation", for_="softshadows.x")
    assert not isinstance(info.value, MissingExtraError) and info.value.name == "no_such_dependency_of_it"
    assert require("math", extra="evaluation", for_="softshadows.x") is __import__("math")


# ----------------------------------------------------------------------------- the scalar fallback


def _fake_mitsuba(llvm_error=None):
    """A stand-in for the mitsuba module whose llvm variant fails to load with ``llvm_error``."""
    mi = types.ModuleType("mitsuba")
    state = {"variant": None, "tried": []}

    def set_variant(name):
        state["tried"].append(name)
        if name.startswith("llvm") and llvm_error is not None:
            raise ImportError(llvm_error)
        state["variant"] = name

    class Scene:
        def ray_test(self, ray):
            return True

    mi.set_variant, mi.variant = set_variant, lambda: state["variant"]
    mi.load_dict = lambda d: Scene()
    mi.Ray3f = mi.Point3f = mi.Vector3f = lambda *a: a
    mi.state = state
    return mi


@pytest.fixture
def fresh_variant(monkeypatch):
    """Variant selection as in a new process (restored afterwards)."""
    monkeypatch.setattr(reference, "_selected", None)
    monkeypatch.delenv("SOFTSHADOWS_MITSUBA_VARIANT", raising=False)
    return monkeypatch


def test_without_llvm_the_references_fall_back_to_scalar_with_a_warning_naming_the_fix(fresh_variant):
    mi = _fake_mitsuba('the LLVM shared library ("libLLVM.so") could not be found!\nSet DRJIT_LIBLLVM_PATH')
    fresh_variant.setitem(sys.modules, "mitsuba", mi)
    with pytest.warns(RuntimeWarning) as caught:
        assert reference.variant() == "scalar_rgb"
    assert mi.state["tried"] == ["llvm_ad_rgb", "scalar_rgb"]
    (warning,) = caught
    message = str(warning.message)
    assert "llvm_ad_rgb variant did not load" in message and "libLLVM.so" in message and "\n" not in message
    assert "scalar_rgb" in message and "slower" in message and "sudo apt-get install -y libllvm19" in message
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert reference.variant() == "scalar_rgb"  # said once, at the selection


@pytest.mark.parametrize("llvm_error, forced, expected", [(None, None, "llvm_ad_rgb"), ("no LLVM", "scalar_rgb", "scalar_rgb")])
def test_no_warning_when_llvm_loads_or_scalar_is_chosen(fresh_variant, llvm_error, forced, expected):
    fresh_variant.setitem(sys.modules, "mitsuba", _fake_mitsuba(llvm_error))
    if forced:
        fresh_variant.setenv("SOFTSHADOWS_MITSUBA_VARIANT", forced)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert reference.variant() == expected


@pytest.mark.mitsuba
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the test hides LLVM by pointing DRJIT_LIBLLVM_PATH at a missing libLLVM.so, a Linux library name; the fallback it checks is the Debian/Ubuntu set-up's")
def test_the_demo_runs_on_scalar_rgb_when_llvm_cannot_load(tmp_path):
    pytest.importorskip("mitsuba")
    code = textwrap.dedent("""
        from softshadows import cli, reference
        status = cli.main(["demo", "--out", "demo", "--size", "24", "--samples", "8", "--reference-samples", "16"])
        print("status", status, reference.variant())
    """)
    # A libLLVM that does not exist: drjit's llvm backend cannot start, as on a machine without LLVM.
    env = {**os.environ, "SOFTSHADOWS_CACHE": str(tmp_path / "cache"), "DRJIT_LIBLLVM_PATH": str(tmp_path / "libLLVM.so")}
    env.pop("SOFTSHADOWS_MITSUBA_VARIANT", None)
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "status 0 scalar_rgb"
    assert "RuntimeWarning: Mitsuba's fast llvm_ad_rgb variant did not load" in done.stderr
    assert "sudo apt-get install -y libllvm19" in done.stderr
    assert (tmp_path / "demo" / "metrics.json").stat().st_size > 0 and (tmp_path / "demo" / "demo.png").exists()
