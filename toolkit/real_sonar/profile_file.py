"""Sonar profile files: the ``nxt`` sonar's model as ``nxtnav sonar fit`` writes it and ``--sonar-profile``
(or ``--sonar FILE``) reads it back.

One typed model, `SonarProfileFile`, is the file: the writer dumps it and the reader validates it, so the
two cannot drift apart, and its JSON Schema is published (``docs/reference/schemas/sonar-profile.json``).
A bad file is one `SonarProfileError` line naming the file, the field (``params.noise_sd``) and the value.

>>> import tempfile
>>> from toolkit.world import NxtSonar
>>> path = Path(tempfile.mkdtemp()) / "p.yaml"
>>> save_sonar_profile(NxtSonar(noise_sd=2.0), path)
>>> load_sonar_profile(path).noise_sd
2.0
>>> _ = path.write_text("params:\\n  noise_sd: -1\\n")
>>> load_sonar_profile(path)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
toolkit.real_sonar.profile_file.SonarProfileError: .../p.yaml: params.noise_sd: -1 is out of its range [0, 100]
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import Field, ValidationInfo, field_validator, model_validator

from ..world import ConfigError, NxtnavError, NxtSonar
from ..world.typed import Typed, build, worded
from ..world.yaml_text import YAMLError, load_yaml

__all__ = ["PROFILE_KIND", "SonarProfileError", "SonarProfileFile", "load_sonar_profile", "save_sonar_profile"]

PROFILE_KIND = "nxtnav-sonar-profile"


class SonarProfileError(NxtnavError, ValueError):
    """A sonar profile file that cannot be used: the message names the file, the field and the problem."""


class SonarProfileFile(Typed):
    """A sonar profile file (YAML): the ``nxt`` sonar's parameters and where they came from."""

    kind: Literal["nxtnav-sonar-profile"] = Field(default="nxtnav-sonar-profile", description="What the file is.")
    sonar: Literal["nxt"] = Field(default="nxt", description="The sonar model the parameters are of.")
    params: NxtSonar = Field(default_factory=NxtSonar, description=(
        "The model's parameters; those left out keep the model's defaults."))
    fit: dict[str, Any] | None = Field(default=None, description=(
        "How the parameters were found (nxtnav sonar fit: sweeps, headings, scores); not read."))

    @model_validator(mode="before")
    @classmethod
    def _known_fields(cls, data: Any) -> Any:
        stray = [str(k) for k in data if k not in cls.model_fields] if isinstance(data, dict) else []
        if stray:
            raise worded(f"unknown field {', '.join(map(repr, stray))} (known: {', '.join(cls.model_fields)})")
        return data

    @field_validator("kind", "sonar", mode="before")
    @classmethod
    def _one_value(cls, value: Any, info: ValidationInfo) -> Any:
        want = cls.model_fields[str(info.field_name)].default
        if value != want:
            raise worded(f"field {info.field_name!r} must be {want!r}, got {value!r}")
        return value


def save_sonar_profile(model: NxtSonar, path: str | Path, *, fit: dict[str, Any] | None = None) -> None:
    """Write `model` as a sonar profile (YAML: kind, sonar, params, and optional fit provenance)."""
    params: dict[str, Any] = {k: (int(v) if k == "beam_rays" else round(float(v), 6))
                              for k, v in asdict(model).items()}
    doc = SonarProfileFile(params=NxtSonar(**params), fit=fit or None)
    data = {k: v for k, v in doc.model_dump(mode="json").items() if v is not None}
    data["params"] = params  # as rounded, in the model's order
    out = Path(path)
    tmp = out.with_name(out.name + ".part")
    text = yaml.safe_dump(data, sort_keys=False)
    try:
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(out)
    finally:  # a failed write leaves neither a half-written profile nor its part file
        tmp.unlink(missing_ok=True)


def load_sonar_profile(path: str | Path) -> NxtSonar:
    """The `nxt` sonar model of a profile file; `SonarProfileError` names the file, field and value on bad
    input (an unknown field or parameter, a value out of its range)."""
    p = Path(path)
    try:
        doc = load_yaml(p.read_text(encoding="utf-8"))
    except OSError as e:
        raise SonarProfileError(f"{p}: cannot read the sonar profile ({e.strerror or e})") from None
    except UnicodeDecodeError:
        raise SonarProfileError(f"{p}: not a sonar profile (not UTF-8 text)") from None
    except YAMLError as e:
        raise SonarProfileError(f"{p}: not valid YAML ({str(e).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise SonarProfileError(f"{p}: a sonar profile is a mapping with 'sonar' and 'params'")
    try:
        return build(SonarProfileFile, doc, str(p)).params
    except ConfigError as e:
        raise SonarProfileError(str(e)) from None
