"""Perception from the car's laser: scans segmented into clusters, boxes fitted to them, tracked over time, and
the tracks' futures predicted."""

from vilma.perception.boxes import BoxParams, fit_boxes, laser_pose
from vilma.perception.metrics import MotFrame, MotScore, clear_mot
from vilma.perception.prediction import predict
from vilma.perception.segment import SegmentParams, scan_points, segment
from vilma.perception.tracker import Track, Tracker, TrackerParams

__all__ = ["BoxParams", "MotFrame", "MotScore", "SegmentParams", "Track", "Tracker", "TrackerParams", "clear_mot",
           "fit_boxes", "laser_pose", "predict", "scan_points", "segment"]
