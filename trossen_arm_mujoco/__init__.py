"""trossen_arm_mujoco: MuJoCo simulation, scripted data collection and sim-to-real replay for
Trossen AI arms (WidowX AI "wxai", Stationary AI kit).

No GL until an image is asked for: importing the package, state-only envs, state-only
recording and the real replay open no GL context and load no GL driver. ``MUJOCO_GL``
defaults to ``egl`` here; that only chooses the backend. dm_control, imported by the
dm_control front doors, would open its backend's display as soon as ``dm_control.mujoco`` is
imported; when this package is imported first, that display is opened by dm_control's first
rendering context instead (see ``_DeferredGLFinder``).

Docs: docs/index.md, docs/concepts/index.md.
"""

import os as _os
import sys as _sys

__all__: list[str] = []  # submodules only: import them by name

# Headless rendering by default (EGL); set MUJOCO_GL yourself to choose another backend.
_os.environ.setdefault("MUJOCO_GL", "egl")

#: MUJOCO_GL values dm_control knows, by its canonical backend name.
_DM_BACKENDS = {
    "glfw": ("glfw", "on", "enable", "enabled", "true", "1", ""),
    "egl": ("egl",),
    "osmesa": ("osmesa",),
}


class _DeferredGLLoader:
    """Loads ``dm_control._render`` with its GL backend imported at the first context.

    dm_control picks and imports its backend when ``dm_control._render`` is imported; the
    EGL backend initializes a display right then (loading the GL driver). This loader runs
    the module with ``MUJOCO_GL=disable`` (nothing imported), then points its ``Renderer``
    at a function that imports the requested backend on first use, and restores ``BACKEND``
    and ``USING_GPU``. If dm_control's layout is not the expected one, the module is simply
    run again the normal way.
    """

    def __init__(self, loader, backend: str, requested: str):
        self.loader, self.backend, self.requested = loader, backend, requested

    def __getattr__(self, name):  # get_source, is_package, ... of the real loader
        return getattr(self.loader, name)

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        import mujoco  # noqa: F401  (mujoco picks its own GL backend at import: not "disable")

        _os.environ["MUJOCO_GL"] = "disable"
        try:
            self.loader.exec_module(module)
        finally:
            _os.environ["MUJOCO_GL"] = self.requested
        try:
            importer = {names[0]: imp for names, imp in module._ALL_RENDERERS}[self.backend]
            gpu = self.backend in module.constants.EGL + module.constants.GLFW
        except (AttributeError, KeyError, TypeError, ValueError):
            self.loader.exec_module(module)  # unexpected dm_control: import it as it wants
            return

        def deferred_renderer(*args, **kwargs):
            module.Renderer = renderer = importer()  # imports the backend: GL opens now
            return renderer(*args, **kwargs)

        module.Renderer = deferred_renderer
        module.BACKEND = self.backend
        module.USING_GPU = gpu


class _DeferredGLFinder:
    """Meta path finder that hands ``dm_control._render`` to ``_DeferredGLLoader``."""

    def find_spec(self, fullname, path, target=None):
        if fullname != "dm_control._render":
            return None
        requested = _os.environ.get("MUJOCO_GL")
        backend = next((b for b, names in _DM_BACKENDS.items() if requested in names), None)
        if backend is None:  # unset, disabled or unknown: dm_control's own behaviour
            return None
        for finder in _sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        if spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = _DeferredGLLoader(spec.loader, backend, requested)
        return spec


if "dm_control._render" not in _sys.modules and not any(
    type(f).__name__ == "_DeferredGLFinder" for f in _sys.meta_path
):
    _sys.meta_path.insert(0, _DeferredGLFinder())

from trossen_arm_mujoco.gym.registration import register_envs as _register_envs  # noqa: E402

_register_envs()  # gymnasium ids "TrossenMujoco/..."; safe to run twice
