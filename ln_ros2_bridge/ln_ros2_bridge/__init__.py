"""ln_ros2_bridge: a ROS 2 node bridging Links and Nodes (LN) topics and services to ROS 2.

Modules: config (YAML), ln_adapter (the LN Python packages, as bytes),
ln_introspection (what the LN manager knows), types (LN definitions <-> ROS
types and codecs, from msg_mapping), topics and services (the data paths),
diagnostics (/diagnostics), bridge
(what runs when), main (the command line).
"""
