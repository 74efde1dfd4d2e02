"""The embedded language model (``--llm local``, the default): a GGUF model in-process via llama.cpp."""
