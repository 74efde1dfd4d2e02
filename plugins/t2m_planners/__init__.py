"""The five task planners of Text2Motion's evaluation: hybrid (Text2Motion), shooting,
greedy-search, and the myopic baselines saycan-gs and innermono-gs (docs/guide/planners.md)."""
