"""PyTorch's ``default_collate`` rules without PyTorch (it is an optional extra, not installed in
every test environment): the structure of ``torch/utils/data/_utils/collate.py`` (PyTorch 2.14,
``collate`` and ``default_collate_fn_map``) with NumPy's ``stack`` where it calls
``torch.stack``/``torch.as_tensor``. What it refuses, PyTorch's DataLoader refuses with
``batch_size > 1``: None and other types (TypeError), NumPy arrays of string or object dtype,
lists of unequal length ("each element in list of batch should be of equal size"), arrays of
unequal shape (``torch.stack``: "stack expects each tensor to be equal size"), a dict key missing
from a later item (KeyError). Unsigned 16/32/64-bit arrays are refused too: PyTorch's are shell
dtypes that ``stack`` and most operations do not take reliably."""

from __future__ import annotations

import collections.abc
import re

import numpy as np

_STRING_OR_OBJECT = re.compile(r"[SaUO]")


def default_collate(batch: list):
    elem = batch[0]
    if isinstance(elem, np.ndarray):
        if _STRING_OR_OBJECT.search(elem.dtype.str) is not None:
            raise TypeError(f"default_collate: batch must contain tensors, numpy arrays, numbers, dicts or lists; "
                            f"found {elem.dtype}")
        if elem.dtype in (np.uint16, np.uint32, np.uint64):
            raise TypeError(f"PyTorch's {elem.dtype} is a shell dtype: torch.stack does not take it reliably")
        if any(b.shape != elem.shape for b in batch):
            raise RuntimeError(f"stack expects each tensor to be equal size, but got {[b.shape for b in batch]}")
        return np.stack(batch, 0)
    if isinstance(elem, (np.bool_, np.number)):
        return np.asarray(batch)
    if isinstance(elem, float):
        return np.asarray(batch, dtype=np.float64)
    if isinstance(elem, int):  # bool too, as in PyTorch's map (bool is an int)
        return np.asarray(batch)
    if isinstance(elem, (str, bytes)):
        return list(batch)
    if isinstance(elem, collections.abc.Mapping):
        return {key: default_collate([d[key] for d in batch]) for key in elem}
    if isinstance(elem, collections.abc.Sequence):
        size = len(elem)
        if not all(len(e) == size for e in batch):
            raise RuntimeError("each element in list of batch should be of equal size")
        return [default_collate(list(samples)) for samples in zip(*batch)]
    raise TypeError(f"default_collate: batch must contain tensors, numpy arrays, numbers, dicts or lists; "
                    f"found {type(elem)}")
