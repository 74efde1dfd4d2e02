"""The language layer shared by every planner and backend: prompts, in-context examples, parsing
and validation of model output, candidate scoring helpers, GBNF grammars and transcripts.

Nothing here imports a model library; backends live in plugins (``t2m_llm_local``, ``t2m_litellm``,
``t2m_llm_replay``).
"""
