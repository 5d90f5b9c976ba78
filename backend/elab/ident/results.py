"""What an identification found (:func:`elab.ident.workflow.run`): frozen dataclasses of
arrays, in full. Serialising (JSON, thinned series) happens at the edge,
:mod:`elab.api.identjson`; the CLI prints them as text.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from elab.ident.advice import Level, Verdict, worst
from elab.ident.data import IdData
from elab.ident.models import ContinuousModel, LinearModel
from elab.ident.nonparametric import Correlation, SineResponse, Spectrum
from elab.ident.subspace import OrderChoice
from elab.ident.validation import Comparison, Residuals

Array = NDArray[np.float64]


@dataclass(frozen=True)
class AnalysedData:
    """The data as analysed: ``z`` holds the ``estimation`` samples and then the
    validation samples, each detrended as the plan asked (the time axis runs on across
    both); the validation samples are the rest of the record (``"split"``) or a separate
    record (``"record"``)."""

    z: IdData
    estimation: int
    validation: Literal["split", "record"]


@dataclass(frozen=True)
class ArxOrderSearch:
    """One output's ARX order search (MATLAB's ``arxstruc`` and ``selstruc``): every
    structure's validation loss, rows [na, nb, nk, V], and the best [na, nb, nk] by the
    loss itself, by AIC and by MDL."""

    output: str
    losses: Array
    best: tuple[int, int, int]
    aic: tuple[int, int, int]
    mdl: tuple[int, int, int]


@dataclass(frozen=True)
class Analyses:
    """The analyses asked for and possible (correlation, spectral and sine analysis need
    one input and one output); ``arx_search`` has one search per output."""

    correlation: Correlation | None = None
    spectral: Spectrum | None = None
    sine: SineResponse | None = None
    arx_search: tuple[ArxOrderSearch, ...] = ()
    n4sid_orders: OrderChoice | None = None


@dataclass(frozen=True)
class Headline:
    """Which validation simulation means something for a model: from a zero initial
    state (``"zero"``, the published figures' convention) or from the estimated one, and
    why."""

    x0: Literal["zero", "estimated"]
    why: str


@dataclass(frozen=True)
class Fits:
    """A model compared with data (fit % per output and the model's output): on the
    validation samples simulated from a zero initial state, from the best initial state,
    and one step ahead; on the estimation samples simulated from the best initial state."""

    validation_simulation: Comparison
    validation_simulation_x0: Comparison
    validation_one_step: Comparison
    estimation_simulation: Comparison
    headline: Headline

    @property
    def headline_fit(self) -> Comparison:
        """The validation simulation the headline names."""
        if self.headline.x0 == "estimated":
            return self.validation_simulation_x0
        return self.validation_simulation


@dataclass(frozen=True)
class ModelResult:
    """A requested model: its name (``n4sid`` with the order chosen), the model with its
    kind's parameters, its fits, its residual analysis (one input and one output, on
    enough validation samples) and the model in continuous time (where one exists)."""

    name: str
    model: LinearModel
    fits: Fits
    residuals: Residuals | None
    continuous: ContinuousModel | None
    verdicts: tuple[Verdict, ...] = ()  # :func:`elab.ident.advice.on_model`

    @property
    def level(self) -> Level:
        """Its worst verdict's level: ``poor`` is not to be designed on as it is."""
        return worst(self.verdicts)


@dataclass(frozen=True)
class Result:
    """Everything an identification found, the verdicts on the data (and on the ARX order
    search) and the notes a reader must see (suspicious data, analyses skipped, unstable
    or reflected models, …)."""

    data: AnalysedData
    analyses: Analyses
    models: tuple[ModelResult, ...]
    notes: tuple[str, ...]
    verdicts: tuple[Verdict, ...] = ()
