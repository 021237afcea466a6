"""The two robots of the ULL course's JSON chain format (figures 3.4 and 3.5: a nested list is a branch of the
chain), lengths in centimetres: shared by the loader's and the CCD solver's tests."""

FIGURE_3_4 = [
    {"type": "rotacion", "th": 0, "a": 5, "limit_inf": 0, "limit_sup": 0.4},
    {"type": "prismatica", "th": 0, "a": 5, "limit_inf": 0, "limit_sup": 2},
    {"type": "rotacion", "th": 0, "a": 5, "limit_inf": 0, "limit_sup": 2},
]
FIGURE_3_5 = [
    {"type": "rotacion", "th": 0, "a": 5, "limit_inf": -5, "limit_sup": 5},
    {"type": "prismatica", "th": 0, "a": 5, "limit_inf": 0, "limit_sup": 1000},
    {"type": "rotacion", "th": 0, "a": 5, "limit_inf": -5, "limit_sup": 5},
    [
        {"type": "rotacion", "th": 0, "a": 5, "limit_inf": -5, "limit_sup": 5},
        {"type": "prismatica", "th": 0, "a": 5, "limit_inf": 0, "limit_sup": 1000},
    ],
]
