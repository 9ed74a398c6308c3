#!/usr/bin/env python3
"""Quickstart (wrapped services API): calls the area services."""

import sys

import links_and_nodes as ln


class area_client(ln.services_wrapper):
    def __init__(self, clnt):
        ln.services_wrapper.__init__(self, clnt, "area_service")
        self.wrap_service("compute_circle_area", "area_service/circle_area")
        self.wrap_service("compute_triangle_area", "area_service/triangle_area")
        self.wrap_service("compute_ellipse_area", "area_service/ellipse_area", default_arguments={"b": 1.0})


clnt = ln.client("test_client", sys.argv)
areas = area_client(clnt)

for radius in (2.0, 0.5):
    result = areas.compute_circle_area(radius)
    print("circle r=%.1f: area %.3f, error code %d" % (radius, result["area"], result["error_code"]))
for radius in (-1.0, 0.0):
    try:
        areas.compute_circle_area(radius=radius)
    except ln.ServiceErrorResponse as error:
        print("circle r=%.1f failed: %s" % (radius, str(error).replace("\n", " | ")))
print("triangle: %.3f" % areas.compute_triangle_area(3.0, height=4.0)["area"])
print("ellipse: %.3f" % areas.compute_ellipse_area(a=2.0)["area"])
svc = clnt.get_service("area_service.compute_circle_area", "area_service/circle_area")
svc.call(radius=3.0)
print("plain call: area %.3f, code %d, message %r" % (svc.resp.area, svc.resp.error_code, svc.resp.error_message))
