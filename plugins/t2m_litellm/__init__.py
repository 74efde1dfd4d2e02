"""Any language model litellm can reach (OpenAI, Anthropic, ollama, OpenAI-compatible servers)."""
