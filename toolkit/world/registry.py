"""A strict name -> class registry shared by the plug-in families (planners, localisers, sonar models)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Generic, TypeVar

from .errors import RegistryError

__all__ = ["Registry"]

T = TypeVar("T")


class Registry(Generic[T]):
    """Classes registered under unique names.

    Parameters
    ----------
    kind : str
        What the registry holds ("planner", "localiser", ...), used in error messages.
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._classes: dict[str, type[T]] = {}

    def add(self, name: str, cls: type[T]) -> None:
        """Register `cls` under `name`; a second class with the same name is an error."""
        if not name or not isinstance(name, str):
            raise RegistryError(f"{self.kind} class {cls.__qualname__} needs a non-empty string name")
        old = self._classes.get(name)
        if old is not None and old is not cls:
            raise RegistryError(
                f"duplicate {self.kind} name {name!r}: {old.__module__}.{old.__qualname__} "
                f"and {cls.__module__}.{cls.__qualname__}"
            )
        self._classes[name] = cls

    def get(self, name: str) -> type[T]:
        """The class registered under `name`; unknown names raise `RegistryError` listing the known ones."""
        try:
            return self._classes[name]
        except KeyError:
            known = ", ".join(sorted(self._classes)) or "none"
            raise RegistryError(f"unknown {self.kind} {name!r}; known: {known}") from None

    def names(self) -> list[str]:
        """Registered names, sorted."""
        return sorted(self._classes)

    def __contains__(self, name: object) -> bool:
        return name in self._classes

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self._classes)
