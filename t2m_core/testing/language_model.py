"""Conformance check for :class:`~t2m_core.protocols.LanguageModel` implementations.

Run it against your backend in your own tests::

    from t2m_core.testing import check_language_model

    def test_my_model_conforms():
        check_language_model(MyModel(MyOptions()))
"""

from __future__ import annotations

import math

from t2m_core.language.grammar import skill_list_grammar
from t2m_core.language.parsing import parse_skill_candidates
from t2m_core.language.prompts import scoring_request
from t2m_core.protocols import LanguageModel, LanguageModelCapabilities

SAMPLE_CONTEXT = (
    "Available primitives: ['pick(a)', 'place(a, b)', 'pull(a, hook)', 'push(a, hook, rack)']\n"
    "Available scene objects: ['table', 'rack', 'red_box']\n"
    "Object relationships: ['on(rack, table)', 'on(red_box, table)']\n"
    "Human instruction: Put the red box on the rack.\n"
    "Top robot action sequence: ['pick(red_box)', 'place(red_box, rack)']\n"
)
SAMPLE_CANDIDATES = ("pick(red_box)", "place(red_box, rack)", "pull(red_box, rack)")


def check_language_model(
    model: LanguageModel,
    *,
    context: str = SAMPLE_CONTEXT,
    candidates: tuple[str, ...] = SAMPLE_CANDIDATES,
    max_tokens: int = 16,
) -> None:
    """Assert that ``model`` behaves as the protocol promises.

    Checks: it satisfies the protocol and declares :class:`LanguageModelCapabilities`; ``complete``
    returns ``n`` strings, is deterministic at temperature 0 and honours stop sequences (no returned
    text contains one); ``score`` returns one finite log-likelihood (≤ 0 nats, up to rounding, for
    exact scorers) per candidate, the same values when asked twice and ``[]`` for no candidates; with
    ``capabilities.grammar``, a grammar-constrained answer parses as a skill list of scene objects.
    """
    assert isinstance(model, LanguageModel), f"{type(model).__name__} lacks complete/score/capabilities"
    assert isinstance(model.capabilities, LanguageModelCapabilities), "capabilities must be LanguageModelCapabilities"

    prompt = context + "Executed action:"
    texts = model.complete(prompt, max_tokens=max_tokens, stop=["\n"], temperature=0.0, n=2)
    assert isinstance(texts, list) and len(texts) == 2, f"complete(n=2) returned {texts!r}"
    assert all(isinstance(text, str) for text in texts), "completions must be strings"
    assert all("\n" not in text for text in texts), f"a completion contains the stop sequence: {texts!r}"
    again = model.complete(prompt, max_tokens=max_tokens, stop=["\n"], temperature=0.0, n=1)
    assert again == texts[:1], f"temperature 0 is not deterministic: {again!r} vs {texts[:1]!r}"

    scoring_prompt, continuations = scoring_request(context, list(candidates))
    scores = model.score(scoring_prompt, continuations)
    assert len(scores) == len(candidates), f"score returned {len(scores)} values for {len(candidates)} candidates"
    assert all(isinstance(value, float) and math.isfinite(value) for value in scores), f"non-finite scores {scores}"
    if model.capabilities.exact_scoring:
        assert all(value <= 1e-6 for value in scores), f"log-likelihoods must be ≤ 0 nats, got {scores}"
    repeated = model.score(scoring_prompt, continuations)
    assert all(math.isclose(a, b, abs_tol=1e-6) for a, b in zip(scores, repeated, strict=True)), (
        f"scores differ between identical calls: {scores} vs {repeated}"
    )
    assert model.score(scoring_prompt, []) == [], "score of no candidates must be []"

    if model.capabilities.grammar:
        objects = ["table", "rack", "red_box"]
        query = context + "Top 5 valid next robot actions (single python list of primitives):"
        answer = model.complete(
            query, max_tokens=64, stop=["\n"], temperature=0.0, grammar=skill_list_grammar(objects)
        )[0]
        parsed = parse_skill_candidates(answer, objects)
        assert parsed.calls and not parsed.rejected, f"grammar-constrained answer does not parse cleanly: {answer!r}"
