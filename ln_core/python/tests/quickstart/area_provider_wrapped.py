#!/usr/bin/env python3
"""Quickstart (wrapped services API): provides area_service.compute_*_area."""

import math
import sys

import links_and_nodes as ln
from area_api_constants import ErrorCodes as ec


def checked(value_name, value):
    if value < 0:
        return "negative %s input value" % value_name, ec.NEGATIVE_INPUT
    if value == 0:
        return "zero in %s input value" % value_name, ec.ZERO_INPUT
    return "", ec.NO_ERROR


class area_provider(ln.service_provider):
    def __init__(self):
        self.clnt = ln.client("test_provider", sys.argv)
        ln.service_provider.__init__(self, self.clnt, "area_service")
        self.wrap_service_provider("compute_circle_area", "area_service/circle_area")
        self.wrap_service_provider("compute_triangle_area", "area_service/triangle_area")
        self.wrap_service_provider("compute_ellipse_area", "area_service/ellipse_area")

    def compute_circle_area(self, radius):
        error_message, error_code = checked("radius", radius)
        area = math.nan if radius < 0 else math.pi * radius**2
        print("circle with radius %5.2f has area %5.2f" % (radius, area))
        return {"area": area, "error_message": error_message, "error_code": error_code}

    def compute_triangle_area(self, base, height):
        error_message, error_code = checked("base", min(base, height))
        area = math.nan if error_code == ec.NEGATIVE_INPUT else base * height / 2
        print("triangle with base %5.2f and height %5.2f has area %5.2f" % (base, height, area))
        return {"area": area, "error_message": error_message, "error_code": error_code}

    def compute_ellipse_area(self, a, b):
        error_message, error_code = checked("axis", min(a, b))
        area = math.nan if error_code == ec.NEGATIVE_INPUT else math.pi * a * b
        print("ellipse with axes %5.2f and %5.2f has area %5.2f" % (a, b, area))
        return {"area": area, "error_message": error_message, "error_code": error_code}


if __name__ == "__main__":
    area_provider().handle_service_group_requests()
