"""A strict name -> class registry shared by the plug-in families (planners, localisers, sonar models).

Besides the classes registered under fixed names, a registry may hold families reached by a prefix:
``ompl:NAME`` is any OMPL geometric planner, built by the family's factory. Lookups, membership and
`Registry.create` treat both alike, so callers never special-case a prefix.

>>> class Shape: ...
>>> reg: Registry[Shape] = Registry("shape")
>>> reg.add("square", Shape)
>>> reg.add_family("poly", lambda n: Shape, lambda: ["hexagon"])
>>> "square" in reg, "poly:hexagon" in reg, "poly:circle" in reg
(True, True, False)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import Any, Generic, TypeVar

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
        self._families: dict[str, tuple[Callable[[str], Callable[..., T]], Callable[[], list[str]]]] = {}
        self._family_classes: dict[str, type[T]] = {}

    def add_family(self, prefix: str, factory: Callable[[str], Callable[..., T]],
                   members: Callable[[], list[str]], cls: type[T] | None = None) -> None:
        """Names ``prefix:NAME`` resolve to ``factory(NAME)`` (a callable building the plug-in) for every
        NAME in ``members()``; `cls` is the class the factory builds (`class_of` answers it)."""
        if not prefix or ":" in prefix or prefix in self._families:
            raise RegistryError(f"{self.kind} family prefix {prefix!r} is empty, has a colon or is taken")
        self._families[prefix] = (factory, members)
        if cls is not None:
            self._family_classes[prefix] = cls

    def _family(self, name: str) -> tuple[str, str] | None:
        prefix, sep, member = name.partition(":")
        return (prefix, member) if sep and prefix in self._families else None

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

    @contextmanager
    def added(self, classes: Mapping[str, type[T]]) -> Iterator[None]:
        """Register `classes` (name -> class) for the length of a ``with`` block, then remove them again.

        For plug-ins of a script, a notebook or a test that should not outlive it; names registered
        before the block stay registered after it.

        >>> class Shape: ...
        >>> reg: Registry[Shape] = Registry("shape")
        >>> with reg.added({"blob": Shape}):
        ...     inside = reg.names()
        >>> inside, reg.names()
        (['blob'], [])
        """
        new = [name for name in classes if name not in self._classes]
        for name, cls in classes.items():
            self.add(name, cls)
        try:
            yield
        finally:
            for name in new:
                self._classes.pop(name, None)

    def get(self, name: str) -> type[T]:
        """The class registered under `name`; other names raise `RegistryError` listing the known ones
        (a family member ``prefix:NAME`` is built by `create`)."""
        if name in self._classes:
            return self._classes[name]
        self.check(name)
        raise RegistryError(f"{self.kind} {name!r} has no class of its own; build it with create()")

    def class_of(self, name: str) -> type[T]:
        """The class of plug-in `name`: the registered class, or the class a family builds its members
        from (given to `add_family`); other names raise `RegistryError` listing the known ones."""
        if name in self._classes:
            return self._classes[name]
        self.check(name)
        family = self._family(name)
        assert family is not None
        if family[0] not in self._family_classes:
            raise RegistryError(f"{self.kind} family {family[0]!r} declared no class")
        return self._family_classes[family[0]]

    def check(self, name: str) -> None:
        """Raise `RegistryError` (listing the known names) unless `name` is registered or a family member."""
        if name in self._classes:
            return
        family = self._family(name)
        if family is not None:
            members = self._families[family[0]][1]()
            if family[1] not in members:
                raise RegistryError(f"unknown {self.kind} {name!r}; known {family[0]}:NAME: {', '.join(members)}")
            return
        known = ", ".join(sorted(self._classes)) or "none"
        more = "".join(f", or {p}:NAME" for p in sorted(self._families))
        raise RegistryError(f"unknown {self.kind} {name!r}; known: {known}{more}")

    def create(self, name: str, *args: Any, **options: Any) -> T:
        """The plug-in `name` (a registered name or ``prefix:NAME``) built with `args` and `options`."""
        if name in self._classes:
            return self._classes[name](*args, **options)
        self.check(name)
        family = self._family(name)
        assert family is not None
        return self._families[family[0]][0](family[1])(*args, **options)

    def names(self) -> list[str]:
        """Registered names, sorted."""
        return sorted(self._classes)

    def family_prefixes(self) -> list[str]:
        """The prefixes of the registered families (``ompl`` for ``ompl:NAME``), sorted."""
        return sorted(self._families)

    def __contains__(self, name: object) -> bool:
        if not isinstance(name, str):
            return False
        family = self._family(name)
        return name in self._classes or (family is not None and family[1] in self._families[family[0]][1]())

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self._classes)
