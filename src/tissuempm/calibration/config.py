"""Calibration config files (TOML), validated with pydantic; unknown keys are rejected by name.

Minimal example (Brewick et al. 2017 style hyper-viscoelastic fit)::

    [model]
    form = "ogden"          # or neo_hookean, mooney_rivlin, yeoh, reduced_polynomial, polynomial, hgo, gent, ...
    terms = 2
    prony_terms = 2         # 0 for a purely hyperelastic fit

    [[data]]
    file = "compression_1000.csv"   # columns strain,stress (engineering strain, nominal stress in Pa)
    strain_rate = -1000.0           # 1/s; negative means compression
    weight = 2.0

    [[data]]
    file = "shear_1.csv"            # columns strain,stress = shear strain gamma, shear stress tau [Pa]
    mode = "shear"                  # simple shear (alias of "simple_shear")
    strain_rate = 1.0               # d gamma/dt [1/s]

    [optimizer]
    method = "globalsearch"         # or "differential_evolution"
    seed = 1

Every other key is optional; see :class:`CalibrationConfig` and ``docs/calibration.md``.
Relative data paths are resolved from the config file's folder.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from tissuempm import options
from tissuempm.calibration.constraints import STABILITY_MODES
from tissuempm.calibration.data import MODE_ALIASES
from tissuempm.calibration.forms import FORMS
from tissuempm.calibration.forward import FORWARDS
from tissuempm.calibration.optimizers import SearchSettings
from tissuempm.calibration.results import OutputOptions
from tissuempm.library.userfile import NAME_PATTERN


class ConfigError(ValueError):
    """A config file is missing, is not valid TOML or does not match the schema."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # inf, nan: "finite number"


class ModelConfig(_Strict):
    """``[model]``: the model form and its fixed settings."""

    form: Literal[FORMS]  # type: ignore[valid-type]
    terms: int | None = Field(None, ge=1, le=6, description="Ogden terms / polynomial order (default per form)")
    prony_terms: int = Field(0, ge=0, le=6, description="Prony terms (0: purely elastic)")
    bulk_modulus: float = Field(2.19e9, gt=0, description="fixed initial bulk modulus K [Pa]")
    density: float = Field(1000.0, gt=0, description="density [kg/m^3]")
    volumetric: Literal["abaqus", "log"] = "abaqus"
    poisson_ratio: float = Field(0.3, gt=-1, lt=0.5, description="fixed Poisson's ratio of a linear_elastic core")
    bounds: dict[str, tuple[float, float]] = Field(default_factory=dict, description="name or name[i] -> [lo, hi]")
    start: dict[str, float] | None = Field(None, description="start point of the first local run (all parameters)")
    stability_range: tuple[float, float] | None = Field(
        None, description="extra stretch range [lo, hi] where Drucker stability is required"
    )
    stability_modes: list[Literal[STABILITY_MODES]] = list(STABILITY_MODES)  # type: ignore[valid-type]
    max_increment: float = Field(0.0025, gt=0, le=0.05, description="strain increment of the viscoelastic history")
    forward: Literal[FORWARDS] = Field(  # type: ignore[valid-type]
        "closed_form", description="incompressible closed forms, or the compressible 3-D driver (slower)")
    fit_bulk_modulus: bool = Field(False, description="fit K too (needs forward = 'driver'); bulk_modulus is its start")

    @field_validator("stability_range")
    @classmethod
    def _stretch_range(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not 0 < v[0] < v[1]:
            raise ValueError(f"stability_range = [lo, hi] needs stretches 0 < lo < hi (got [{v[0]:g}, {v[1]:g}])")
        return v

    @model_validator(mode="after")
    def _bulk_needs_driver(self) -> ModelConfig:
        if self.fit_bulk_modulus and self.forward != "driver":
            raise ValueError("fit_bulk_modulus = true needs forward = 'driver' (the incompressible closed forms "
                             "do not depend on K)")
        return self


class DataConfig(_Strict):
    """``[[data]]``: one data file."""

    file: str
    strain_rate: float | None = Field(None, description="1/s, negative in compression; omit for quasi-static")
    weight: float = Field(1.0, ge=0, description="weight in the total cost; 0 shows the data set without fitting it")
    mode: Literal[tuple(MODE_ALIASES)] | None = None  # type: ignore[valid-type]
    stress_unit: Literal["Pa", "kPa", "MPa", "GPa"] | None = None
    strain_unit: Literal["1", "-", "percent", "%"] | None = None
    points: int = Field(20, ge=2, le=10_000, description="equally spaced points per curve (report: 20)")
    positive_compression: bool = False
    name: str | None = None

    @field_validator("strain_rate")
    @classmethod
    def _nonzero(cls, v: float | None) -> float | None:
        if v is not None and v == 0:
            raise ValueError("strain_rate must be non-zero (omit it for quasi-static data)")
        return v


OPTIMIZER_KEYS = ("method", "seed", "local_solver", "trial_points", "stage1_points", "max_local_runs",
                  "min_local_runs", "local_maxiter", "popsize", "maxiter", "polish")
"""The settings of :class:`~tissuempm.calibration.optimizers.SearchSettings` an ``[optimizer]`` table
holds (their types, ranges and defaults are SearchSettings'; ``start`` is ``model.start``)."""


class OptimizerConfig(options.section(SearchSettings, _Strict, "OptimizerOptions", include=OPTIMIZER_KEYS)):  # type: ignore[misc]
    """``[optimizer]``: the global search, the settings :data:`OPTIMIZER_KEYS` of
    :class:`tissuempm.calibration.optimizers.SearchSettings` (``trial_points`` default 50 n,
    ``stage1_points`` trial_points / 5, ``max_local_runs`` 4 n, ``min_local_runs`` ceil(2.5 n) for
    n free parameters; ``seed`` 0..2^32-1, NumPy's range)."""


class AnalysisConfig(_Strict):
    """``[analysis]``: identifiability and model selection."""

    standard_errors: bool = True
    profile: bool = False
    profile_points: int = Field(11, ge=3)
    bootstrap: int = Field(0, ge=0, description="residual-bootstrap replicates (0: none)")
    compare_terms: list[int] = Field(default_factory=list, description="term counts compared by AIC/BIC")
    forms: list[str] = Field(default_factory=list, description='model forms ranked by AIC/BIC and holdout, '
                                                              'e.g. ["ogden:3", "yeoh", "neo_hookean"]')
    holdout: list[str] = Field(default_factory=list, description="modes or data names left out of the "
                                                                "model-selection fits and predicted")

    @field_validator("forms")
    @classmethod
    def _form_specs(cls, v: list[str]) -> list[str]:
        from tissuempm.calibration.selection import parse_form

        for spec in v:
            parse_form(spec)
        if len(set(v)) != len(v):
            raise ValueError(f"forms lists a form twice: {v}")
        return v

    @field_validator("holdout", mode="before")
    @classmethod
    def _one_or_list(cls, v: object) -> object:
        return [v] if isinstance(v, str) else v

    @model_validator(mode="after")
    def _holdout_needs_forms(self) -> AnalysisConfig:
        if self.holdout and not self.forms:
            raise ValueError(f"holdout = {self.holdout} needs forms = [...] (the held-out data are predicted by "
                             "the model-selection fits)")
        return self


class OutputConfig(options.section(OutputOptions, _Strict, "OutputOptions")):  # type: ignore[misc]
    """``[output]``: names and files: ``name`` and the options of
    :class:`tissuempm.calibration.results.OutputOptions` (title, plots, plot_rates, lsdyna_units)."""

    name: str | None = Field(None, description="library name of the fitted material, snake_case (default: the "
                                                "config file stem in lowercase, other characters replaced by _)")

    @field_validator("name")
    @classmethod
    def _snake_case(cls, v: str | None) -> str | None:
        if v is not None and not NAME_PATTERN.match(v):
            raise ValueError("must be a snake_case library key: a lowercase letter, then lowercase letters, digits, _")
        return v


class CalibrationConfig(_Strict):
    """A whole calibration config."""

    model: ModelConfig
    data: list[DataConfig] = Field(min_length=1)
    optimizer: OptimizerConfig = OptimizerConfig()
    analysis: AnalysisConfig = AnalysisConfig()
    output: OutputConfig = OutputConfig()


def default_name(config: Path) -> str:
    """Library name from a config file name: ``Brain-Fit.toml`` -> ``brain_fit`` (``m_`` prefixed if needed)."""
    name = re.sub(r"[^a-z0-9_]", "_", config.stem.lower())
    return name if NAME_PATTERN.match(name) else f"m_{name}"


def load_config(path: str | Path) -> CalibrationConfig:
    """Read and validate a config file (raises :class:`ConfigError` with every problem listed,
    :func:`tissuempm.config_files.load`)."""
    from tissuempm.config_files import load

    return load(path, CalibrationConfig, "calibration config", ConfigError)
