"""Import Open3D even where the system lacks libusb-1.0.

Open3D's extension links against ``libusb-1.0.so.0``. Debian ships it as ``libusb-1.0-0``;
without root, PyPI's ``libusb-package`` carries the same library, and loading it globally
before Open3D lets the dynamic linker resolve the dependency by its soname.
"""

import ctypes
import importlib


def import_open3d():
    try:
        return importlib.import_module("open3d")
    except ImportError as error:
        if "libusb" not in str(error):
            raise
        import libusb_package

        ctypes.CDLL(str(libusb_package.get_library_path()), mode=ctypes.RTLD_GLOBAL)
        return importlib.import_module("open3d")
