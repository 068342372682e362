"""Network weights and optimiser state as plain NPZ files, never pickle.

Why: the project's files that users keep are plain JSON / NPZ / CSV, readable without running code from the file.
torch's own format is a zip of pickles (safe to load only with `weights_only=True`, and unreadable without torch);
here every tensor is an array named `<part>/<parameter>` (e.g. `actor/gru.weight_ih_l0`), the optimiser's
per-parameter state `optim/state/<index>/<name>`, and its hyper-parameters (`param_groups`) one JSON text array.
The tensors come back bit for bit, so a run resumed from these files continues exactly.
"""
from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

FORMAT = "mahn-lean-weights/1"


def save_weights(path: str | Path, parts: Mapping[str, Mapping[str, torch.Tensor]],
                 optim: Mapping[str, Any] | None = None) -> None:
    """Write state dicts (`parts`: name -> module.state_dict()) and an optimiser's state_dict, atomically."""
    arrays: dict[str, np.ndarray] = {"format": np.array(FORMAT)}
    for part, state in parts.items():
        for name, tensor in state.items():
            arrays[f"{part}/{name}"] = tensor.detach().cpu().numpy()
    if optim is not None:
        for index, state in optim["state"].items():
            for name, value in state.items():
                arrays[f"optim/state/{index}/{name}"] = (value.detach().cpu().numpy() if torch.is_tensor(value)
                                                         else np.asarray(value))
        arrays["optim/param_groups"] = np.array(json.dumps(optim["param_groups"]))
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        np.savez(f, **arrays)  # type: ignore[arg-type]  # numpy types **kwds as if one could be allow_pickle
    os.replace(tmp, path)


def load_weights(path: str | Path) -> dict[str, Any]:
    """{part: state dict, ..., "optim": optimiser state dict (when saved)}; a damaged or foreign file is a
    ValueError naming it."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as f:
            arrays = {k: f[k] for k in f.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(f"weights file {str(path)!r} is missing or damaged ({exc})") from exc
    if arrays.pop("format", np.array("")).item() != FORMAT:
        raise ValueError(f"weights file {str(path)!r} is not a {FORMAT} file")
    out: dict[str, Any] = {}
    groups = arrays.pop("optim/param_groups", None)
    optim_state: dict[int, dict[str, torch.Tensor]] = {}
    for key, value in arrays.items():
        if key.startswith("optim/state/"):
            index, name = key[len("optim/state/"):].split("/", 1)
            optim_state.setdefault(int(index), {})[name] = torch.from_numpy(np.array(value))
        else:
            part, name = key.split("/", 1)
            out.setdefault(part, {})[name] = torch.from_numpy(np.array(value))
    if groups is not None:
        out["optim"] = {"state": optim_state, "param_groups": json.loads(groups.item())}
    return out
