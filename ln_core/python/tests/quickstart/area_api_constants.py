"""Error codes of the area services (quickstart)."""


class ErrorCodes:
    NO_ERROR = 0
    NEGATIVE_INPUT = 1
    ZERO_INPUT = 2
