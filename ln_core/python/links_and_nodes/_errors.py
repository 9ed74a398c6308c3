"""LN error codes and the exception every failing LN operation raises."""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from . import _ln

# The LN 2.9 numbering (starting at 1), written out so that type checkers and editors know them.
LNE_CHECK_ERRNO: Final = 1
LNE_NO_MEM: Final = 2
LNE_NO_MANAGER_ADDRESS: Final = 3
LNE_INVALID_MANAGER_ADDRESS: Final = 4
LNE_INVALID_HOSTNAME: Final = 5
LNE_UNKNOWN_HOSTNAME: Final = 6
LNE_HOST_WRONG_NET: Final = 7
LNE_GOT_INVALID_RESPONSE: Final = 8
LNE_REGISTER_DENIED: Final = 9
LNE_CLIENT_NOT_INITIALIZED: Final = 10
LNE_REQUEST_FAILED: Final = 11
LNE_FIELD_NOT_IN_HEADER: Final = 12
LNE_STRING_LENGTH_SPEC_MISSING: Final = 13
LNE_PORT_NOT_FOUND: Final = 14
LNE_INVALID_PORT_OBJECT: Final = 15
LNE_SHM_IS_TOO_SMALL: Final = 16
LNE_SHM_IS_TOO_BIG: Final = 17
LNE_SHM_DOES_NOT_EXIT: Final = 18
LNE_PACKET_TOO_LARGE: Final = 19
LNE_SHM_READ_ERROR: Final = 20
LNE_LOST_CONNECTION: Final = 21
LNE_REGISTER_FAILED: Final = 22
LNE_SVC_IS_PROVIDER: Final = 23
LNE_SVC_IS_CLIENT: Final = 24
LNE_SVC_RECV_RESP: Final = 25
LNE_SVC_RECV_RESP_MEM: Final = 26
LNE_SVC_ALREADY_REGISTERED: Final = 27
LNE_SVC_NOT_REGISTERED: Final = 28
LNE_SVC_RECV_REQ: Final = 29
LNE_SVC_RECV_REQ_MEM: Final = 30
LNE_SVC_REQ_SET_DATA_WRONG: Final = 31
LNE_SVC_HANDLER_NO_RESP: Final = 32
LNE_INVALID_REQ_FIELD_FORMAT: Final = 33
LNE_USER_DEFINED_ERROR: Final = 34
LNE_SVC_NO_HANDLER: Final = 35
LNE_SVC_HANDLER_EXC: Final = 36
LNE_SVC_REQ_RUNNING: Final = 37
LNE_SVC_REQ_NOT_RUNNING: Final = 38
LNE_SVC_REQ_ABORTED: Final = 39
LNE_NO_PROVIDER_FOUND: Final = 40
LNE_START_PROVIDER_FAILED: Final = 41
LNE_ERROR_GETTING_SHM_FD: Final = 42
LNE_SHM_NAME_TOO_LONG: Final = 43
LNE_NOT_YET_IMPLEMENTED: Final = 44
LNE_NO_LOGGER_TOPICS: Final = 45
LNE_INTERNAL_ERROR: Final = 46
LNE_TOPIC_ID_OUT_OF_RANGE: Final = 47
LNE_LOG_FILE_TOO_NEW: Final = 48
LNE_WRONG_BYTE_ORDER: Final = 49
LNE_INVALID_SHM_MAGIC: Final = 50
LNE_SHM_VERSION_TOO_NEW: Final = 51
LNE_WRONG_SHM_SIZE: Final = 52
LNE_INVALID_SIGNATURE: Final = 53
LNE_INVALID_PARAMETER: Final = 54
LNE_SVC_RESP_LATER: Final = 55
LNE_SVC_GRP_UNKNOWN: Final = 56
LNE_THREADP_INIT: Final = 57
LNE_NOT_ON_THIS_OS: Final = 58
LNE_PORT_UNBLOCKED: Final = 59
LNE_UNKNOWN_PARAMETER: Final = 60
LNE_SVC_HANDLER_MULTI_RESP: Final = 61
LNE_MANAGER_TOO_OLD: Final = 62
LNE_INVALID_DSA_SIGNATURE: Final = 63
LNE_SVC_TIMEOUT: Final = 64
LNE_SVC_GRP_HANDLED_IN_POOL: Final = 65
LNE_CLNT_NAME_IN_USE: Final = 66
LNE_CHECK_ERROR_CODE: Final = 67
LNE_UNKNOWN: Final = 68
LNE_WRONG_MD_HASH: Final = 69

#: {"LNE_NO_MEM": 2, ...}
ERROR_CODES: Final[dict[str, int]] = {name: value for name, value in globals().items() if name.startswith("LNE_")}
_NAMES_BY_CODE = {value: name for name, value in ERROR_CODES.items()}

if TYPE_CHECKING:

    class LNError(Exception):
        """A failed LN operation (raised by the native module)."""

        @property
        def message(self) -> str: ...
        @property
        def code(self) -> int: ...
        @property
        def user_code(self) -> int: ...

else:
    LNError = _ln.LNError
    LNError.__module__ = "links_and_nodes"
    LNError.message = property(lambda self: self.args[0] if self.args else "", doc="the error text")
    LNError.code = property(
        lambda self: self.args[1] if len(self.args) > 1 else LNE_UNKNOWN,
        doc="the LNE_* number",
    )
    LNError.user_code = property(
        lambda self: self.args[2] if len(self.args) > 2 else 0,
        doc="for LNE_USER_DEFINED_ERROR: the error code the provider's handler returned",
    )
    LNError.__str__ = lambda self: str(self.args[0]) if self.args else ""


def error_name(code: int) -> str:
    """'LNE_SVC_TIMEOUT' for 64 (or -64)."""
    return _NAMES_BY_CODE.get(abs(code), "LNE_UNKNOWN")
