"""Packages that are also their command's library function.

``record``, ``benchmark`` and ``study`` each name a subpackage and the library function of a
command, and ``from viewer_slam import record`` must give something to call while
``import viewer_slam.record.session`` keeps working. Python binds a subpackage to its parent's
attribute of the same name when the subpackage loads, whatever the parent's ``__getattr__``
would say, so the attribute cannot be the function. Instead, each of these packages is made
callable: calling the package calls its command's function (imported on the first call, so
importing the package stays light).
"""

import importlib
import sys
from types import ModuleType
from typing import Any, cast


class CommandPackage(ModuleType):
    """A package that, called, calls its command's function (``__command__``: module and function name)."""

    __command__: tuple[str, str]

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        module, function = self.__command__
        return getattr(importlib.import_module(module), function)(*args, **kwargs)


def make_callable(package: str, module: str, function: str) -> None:
    """Make the loaded ``package`` a :class:`CommandPackage` calling ``function`` of ``module``."""
    loaded = sys.modules[package]
    loaded.__class__ = CommandPackage
    cast(CommandPackage, loaded).__command__ = (module, function)
