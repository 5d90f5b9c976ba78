"""System identification: data sets, non-parametric and parametric estimation,
order selection and model validation (Ljung 1999; Van Overschee & De Moor 1996)."""

from elab.ident.data import IdData, iddata, require_exciting

__all__ = ["IdData", "iddata", "require_exciting"]
