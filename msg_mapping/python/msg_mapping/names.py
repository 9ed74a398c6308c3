"""LN topic and service names <-> ROS 2 names: LN `a.b.c` is ROS `/a/b/c`.

The one rule the bridge (ln_ros2_bridge) and recordings (ln_bag) name ROS
topics and services by. Characters ROS does not allow in a name token become
'_' and a token that would start with a digit gets 'ln_', so the mapping is
only reversible for names that need neither (recordings keep the LN name).
"""

import re


def ros_token(component):
    """One component of an LN name as a ROS name token."""
    token = re.sub(r"[^A-Za-z0-9_]", "_", component)
    if not token or token[0].isdigit():
        token = "ln_" + token
    return token


def ros_name_for(ln_name, prefix="/"):
    """LN `a.b.c` -> ROS `/a/b/c` (below `prefix`, e.g. "/robot1")."""
    return prefix.rstrip("/") + "/" + "/".join(ros_token(c) for c in ln_name.split(".") if c)


def ln_name_for(ros_name):
    """ROS `/a/b/c` -> LN `a.b.c` (the inverse of ros_name_for for names it produced)."""
    return ".".join(t for t in ros_name.split("/") if t)
