"""links_and_nodes: the Python API of Links and Nodes (LN 2.9), on ln_core.

    import links_and_nodes as ln
    clnt = ln.client("my_program")           # manager from $LN_MANAGER
    port = clnt.publish("counter.counts", "counter/count_message")
    port.packet.num_counts = 1
    port.write()

Scripts written for LN 2.9's Python package run unchanged. Additions of
ln_core (marked so in their docstrings): port.borrow() (zero-copy reads),
port.sample_info, service_wrapper.call_future(), request.respond_error(),
client.wait_for_service(), client.set_*_availability_handler(),
client.list_topics()/list_clients()/list_services()/get_manager_status()
(introspection: topic_info, client_info, service_info, manager_status),
client.list_processes()/control_process()/get_process_output() (the
manager's processes: process_info, process_output),
event_connection_wrapper.id/disconnect(), client.close() and typed errors (LNError with .code, FieldError).
"""

from . import _ln
from ._client import borrowed_packet, client, multi_waiter, port_wrapper
from ._errors import *  # noqa: F403  (LNE_* constants)
from ._errors import ERROR_CODES, LNError, error_name
from ._events import event_connection_wrapper
from ._introspection import client_info, manager_status, process_info, process_output, service_info, topic_info
from ._ln import (
    LN_LIBRARY_VERSION,
    LN_PARAM_BOOLEAN,
    LN_PARAM_DOUBLE,
    LN_PARAM_INT8,
    LN_PARAM_INT16,
    LN_PARAM_INT32,
    LN_PARAM_INT64,
    LN_PARAM_SINGLE,
    LN_PARAM_UINT8,
    LN_PARAM_UINT16,
    LN_PARAM_UINT32,
    LN_PARAM_UINT64,
    RATE_AS_PUBLISHED,
    RATE_ON_REQUEST_LAST,
)
from ._loggers import logger, logger_data, logger_data_wrapper, logger_topic_, topic_cursor_wrapper
from ._mainloop import GLibMainloop, MainloopInterface, MainloopMultiWaiter, SelectMainloop
from ._packets import FieldError, FieldTypeError, FieldValueError
from ._packets import Part as ln_packet_part
from ._parameters import ParameterBlock, ParameterOutputs, ParameterSignal, parameters_proxy
from ._services import SVC_RESP_LATER, ServiceFuture, request_wrapper, service_wrapper
from ._wrapped import (
    ServiceErrorResponse,
    service_provider,
    services_wrapper,
    wrapped_service,
    wrapped_service_provider,
)

ln_packet = ln_packet_part
LN_MANAGER_CLIENT_ID = 0xFFFFFFFF
#: LN's C API names it "the next packet on request"; as in LN 2.9 it is
#: served like RATE_ON_REQUEST_LAST (a read returns the newest packet).
RATE_ON_REQUEST_NEXT = -3

get_time = _ln.get_time
dsa_dss1_sign_message = _ln.dsa_dss1_sign_message
dsa_dss1_generate_key_pair = _ln.dsa_dss1_generate_key_pair
get_monotonic_time = _ln.get_monotonic_time
format_error = _ln.format_error
from ._packets import ctor_name as get_packet_ctor_name  # noqa: E402
