"""The ``replay`` language model: answers from a recorded transcript, for offline reproduction and tests."""
