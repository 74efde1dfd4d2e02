"""One embedded model per test session (loading it takes a few seconds and ~0.5 GB)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def local_model():
    from t2m_llm_local.hooks import LocalModelOptions
    from t2m_llm_local.llama import LocalLanguageModel

    return LocalLanguageModel(LocalModelOptions(model="qwen2.5-coder-0.5b", n_ctx=4096))  # mechanics, not quality: the fast model
