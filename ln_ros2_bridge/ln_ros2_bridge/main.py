"""ln_ros2_bridge: bridges an LN instance and a ROS 2 domain.

    ln_ros2_bridge --config bridge.yaml [--ln-manager HOST:PORT] [--ros-args ...]

Exit status: 0 after SIGINT/SIGTERM, 2 for a bad configuration (the message
says what and where), 1 for anything else that stops it from starting.
Which LN package is used (LN 2.9's or ln_core's links_and_nodes) is decided by
PYTHONPATH; the log says which one was found. The bridge logs through the ROS
logger of its node (console and /rosout).
"""

import argparse
import logging
import os
import signal
import sys
import threading

from .config import ConfigError, load_config, with_overrides


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="ln_ros2_bridge",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--config", "-c", required=True, help="the bridge's YAML configuration")
    parser.add_argument("--ln-manager", help="HOST:PORT of the LN manager (overrides ln.manager and $LN_MANAGER)")
    parser.add_argument("--node-name", help="ROS node name (overrides ros.node_name)")
    parser.add_argument("--ln-client-name", help="LN client name (overrides ln.client_name)")
    parser.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    parser.add_argument("--check", action="store_true", help="only check the configuration, then exit")
    return parser.parse_args(argv)


class RosLogHandler(logging.Handler):
    """The bridge's Python log records -> its node's ROS logger (console and
    /rosout); logger `ln_ros2_bridge.x` becomes the node logger's child `x`."""

    def __init__(self, node_logger):
        super().__init__()
        self._root = node_logger
        self._children = {}

    def emit(self, record):
        try:
            from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
            from rclpy.logging import LoggingSeverity

            logger = self._root
            prefix = "ln_ros2_bridge."
            if record.name.startswith(prefix):
                child = record.name[len(prefix) :]
                logger = self._children.get(child)
                if logger is None:  # get_child() also makes /rosout carry the child's records
                    logger = self._children[child] = self._root.get_child(child)
            # Python's levels are rcutils' severities (10 debug ... 50 fatal)
            severity = LoggingSeverity(10 * (min(max(record.levelno, 10), 50) // 10))
            if logger.is_enabled_for(severity):
                # what RcutilsLogger.log() ends in, with the location of the Python record
                # (its own call-site bookkeeping would see one caller for every record)
                _rclpy.rclpy_logging_rcutils_log(
                    severity, logger.name, self.format(record), record.funcName, record.pathname, record.lineno
                )
        except Exception:  # logging must never take the bridge down
            self.handleError(record)


def use_ros_logging(node, level_name):
    """Routes the `ln_ros2_bridge` Python loggers to the node's ROS logger at `level_name`."""
    from rclpy.logging import LoggingSeverity

    node.get_logger().set_level(LoggingSeverity[level_name.upper().replace("WARNING", "WARN")])
    root = logging.getLogger("ln_ros2_bridge")
    root.handlers[:] = [RosLogHandler(node.get_logger())]
    root.setLevel(getattr(logging, level_name.upper()))
    root.propagate = False


FASTDDS_PROFILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "fastdds_profile.xml")


def use_bridge_fastdds_profile():
    """Gives the bridge's Fast DDS participant the bridge's profile (a 32 MiB shared-memory
    segment, for large packets) unless the environment names a profile. Returns the profile
    in use. Must run before rclpy.init()."""
    for name in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
        if os.environ.get(name):
            return os.environ[name]
    if os.path.exists(FASTDDS_PROFILE):
        os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = FASTDDS_PROFILE
        return FASTDDS_PROFILE
    return None


def main(argv=None):
    import rclpy
    from rclpy.utilities import remove_ros_args

    argv = list(sys.argv if argv is None else argv)
    args = parse_args(remove_ros_args(argv)[1:])
    log = logging.getLogger("ln_ros2_bridge")
    try:
        config = with_overrides(
            load_config(args.config),
            ln_manager=args.ln_manager,
            ros_node_name=args.node_name,
            ln_client_name=args.ln_client_name,
        )
        if not config.is_bridge_name(config.ln_client_name) or not config.is_bridge_name(config.ros_node_name):
            raise ConfigError(
                "%s: the names %r / %r must match loop_prevention.bridge_names %s"
                % (config.source, config.ln_client_name, config.ros_node_name, list(config.bridge_names))
            )
        if not config.ln_manager:
            raise ConfigError("%s: no LN manager address: set ln.manager, $LN_MANAGER or --ln-manager" % config.source)
    except ConfigError as error:
        print("ln_ros2_bridge: configuration error: %s" % error, file=sys.stderr)
        return 2
    if args.check:
        print(
            "ln_ros2_bridge: %s is valid (%d topics, %d services, auto %s)"
            % (config.source, len(config.topics), len(config.services), "on" if config.auto.enabled else "off")
        )
        return 0

    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

    from .bridge import Bridge
    from .types import UnknownType

    profile = use_bridge_fastdds_profile()
    rclpy.init(args=argv)
    node = rclpy.create_node(config.ros_node_name, namespace=config.ros_namespace or None)
    use_ros_logging(node, args.log_level)
    log.debug("Fast DDS profile: %s", profile or "Fast DDS's defaults")
    try:
        bridge = Bridge(config, node)
    except UnknownType as error:  # e.g. a rule file that does not compile
        print("ln_ros2_bridge: configuration error: %s" % error, file=sys.stderr)
        node.destroy_node()
        rclpy.shutdown()
        return 2
    executor = MultiThreadedExecutor(num_threads=config.executor_threads)  # services (topics have threads of their own)
    executor.add_node(node)
    stop = threading.Event()

    def on_signal(signum, frame):
        stop.set()
        executor.wake() if hasattr(executor, "wake") else None

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    bridge.start()
    log.info(
        "ln_ros2_bridge running as ROS node %s, LN client %r (config %s)",
        bridge.node_fq_name,
        config.ln_client_name,
        config.source,
    )
    try:
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.2)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        log.info("ln_ros2_bridge stopping")
        bridge.stop()
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
