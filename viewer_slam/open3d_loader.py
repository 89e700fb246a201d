"""Import Open3D even where the system lacks libusb-1.0, and quiet.

Open3D's extension links against ``libusb-1.0.so.0``. Debian ships it as ``libusb-1.0-0``;
without root, PyPI's ``libusb-package`` carries the same library, and loading it globally
before Open3D lets the dynamic linker resolve the dependency by its soname.

Open3D prints its warnings on stderr itself; its errors it raises as exceptions, which the
callers turn into their own line. So it is held to errors only, at its source.
"""

import ctypes
import importlib


def import_open3d():
    o3d = _import()
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    return o3d


def _import():
    try:
        return importlib.import_module("open3d")
    except ImportError as error:
        if "libusb" not in str(error):
            raise
        import libusb_package

        ctypes.CDLL(str(libusb_package.get_library_path()), mode=ctypes.RTLD_GLOBAL)
        return importlib.import_module("open3d")
