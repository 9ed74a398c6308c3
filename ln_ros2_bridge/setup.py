from setuptools import setup

package_name = "ln_ros2_bridge"

setup(
    name=package_name,
    version="0.1.0",
    packages=[package_name],
    package_data={package_name: ["fastdds_profile.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml", "README.md"]),
        ("share/" + package_name + "/config", ["config/example.yaml"]),
    ],
    install_requires=["setuptools", "pyyaml"],
    zip_safe=True,
    description="ROS 2 node bridging Links and Nodes (LN) topics and services to ROS 2",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "ln_ros2_bridge = ln_ros2_bridge.main:main",
        ],
    },
)
