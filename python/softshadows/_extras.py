"""Optional dependencies: ``pip install softshadows`` installs the core (the methods, scenes,
lights, cameras, ``shading``, ``rmse``/``psnr`` of ``metrics``); the evaluation stack (Mitsuba,
pandas, matplotlib, scikit-image, flip-evaluator, OpenEXR, Jinja2) is the ``evaluation`` extra
and the sample meshes' pymeshlab the ``models`` extra (pyproject.toml).

Every import of an optional package goes through :func:`require`, so that a missing one raises
a ``ModuleNotFoundError`` that names what needed it and the extra that installs it, at the call
that needs it: ``import softshadows`` itself never imports them.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["require", "MissingExtraError", "DISTRIBUTIONS"]

#: The PyPI name of each optional top-level module whose name differs from it, for the message.
DISTRIBUTIONS = {"skimage": "scikit-image", "flip_evaluator": "flip-evaluator", "OpenEXR": "openexr",
                 "jinja2": "Jinja2", "drjit": "mitsuba"}


class MissingExtraError(ModuleNotFoundError):
    """An optional package is not installed; ``extra`` names the extra of softshadows that installs it."""

    def __init__(self, message: str, *, name: str, extra: str):
        super().__init__(message, name=name)
        self.extra = extra


def require(module: str, *, extra: str, for_: str) -> ModuleType:
    """Imports ``module`` (dotted names too) or raises naming the extra that installs it.

    Parameters
    ----------
    module : str
        The module to import, e.g. ``"pandas"`` or ``"skimage.metrics"``.
    extra : str
        The extra of softshadows that installs it, e.g. ``"evaluation"``.
    for_ : str
        What needs it, for the message, e.g. ``"softshadows.metrics.ssim"``.

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingExtraError
        A ``ModuleNotFoundError``, ``"<for_> needs <distribution>: pip install 'softshadows[<extra>]'"`` when the module's
        package is not installed. A module that is installed but fails to import for another
        reason (one of its own dependencies missing, a broken build) raises its own error.

    Examples
    --------
    >>> from softshadows._extras import require
    >>> require("no_such_package.sub", extra="evaluation", for_="softshadows.example")
    Traceback (most recent call last):
    ...
    softshadows._extras.MissingExtraError: softshadows.example needs no_such_package: pip install 'softshadows[evaluation]'
    """
    top = module.split(".")[0]
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        # Only the package itself missing (or blocked: None in sys.modules, where importing a
        # submodule reports the dotted name) means "install the extra".
        if exc.name is None or exc.name.split(".")[0] != top:
            raise
        dist = DISTRIBUTIONS.get(top, top)
        raise MissingExtraError(f"{for_} needs {dist}: pip install 'softshadows[{extra}]'", name=top, extra=extra) from exc
