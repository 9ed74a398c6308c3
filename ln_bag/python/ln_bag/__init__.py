"""ln_bag: recordings of LN systems as MCAP files that ROS 2 tools read.

The commands are `ln record`, `ln play`, `ln bag info` and `ln bag convert`
(see the package README). From Python:

    from ln_bag import McapWriter, TopicMapping
    mapping = TopicMapping("my_robot/pose", md_dirs=["defs"])   # ROS type, ros2msg schema, codec
    writer = McapWriter("out.mcap")
    channel = writer.add_channel(writer.add_schema(mapping.ros_type, "ros2msg", mapping.schema),
                                 "/my_robot/pose", "cdr", {})
    writer.add_message(channel, sequence, log_time_ns, publish_time_ns, mapping.ln_to_cdr(packet))
    writer.close()
"""

from ._native import BagError, McapWriter, Recorder, TopicMapping

__all__ = ["BagError", "McapWriter", "Recorder", "TopicMapping"]
