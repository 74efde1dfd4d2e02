"""The language layer shared by every planner and backend: prompts, in-context examples and their
selection, parsing and validation of model output, goal checks ("no valid goal") and semantic goal
judgement, the goal evaluation set, candidate scoring helpers, GBNF grammars and transcripts.

Nothing here imports a model library; backends live in plugins (``t2m_llm_local``, ``t2m_litellm``,
``t2m_llm_replay``).
"""
