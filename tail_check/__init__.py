"""Red tail-disc detection on last-car snapshots, for semi-automatic block clearance.

Pure algorithms (numpy, OpenCV): the paper's colour method (Gaussian low-pass,
per-channel band ``c_ref ± c_Δ``) with disc-consistency checks, camera profiles,
calibration, the two-camera comparison, overlays for the review screen and the
ε(c_Δ) study. Images are BGR ``uint8`` arrays as OpenCV decodes them.

Public API::

    detect(image_bgr, profile=None) -> DetectionResult (the hand-tuned detector)
    confirm(image_bgr, result) -> DetectionResult (a present the learned verifier doubts
        becomes uncertain)
    detect_confirmed(image_bgr, profile=None) -> DetectionResult (detect, then confirm:
        the service's and the CLI's verdict)
    compare(departure_bgr, arrival_bgr, profile=None) -> Comparison
    compare_with_departure(departure_result, departure_bgr, arrival_bgr, profile=None)
    calibrate(image_bgr, (x, y)) -> CameraProfile
    render_overlay(image_bgr, result, profile=None) -> BGR array; overlay_png(...) -> bytes;
    recorded_result(stored verdict dict) -> the DetectionResult to draw
    decode_snapshot(data) -> BGR array (EXIF orientation ignored)
    detect_snapshot(jpeg_bytes, profile=None) -> DetectionResult (JPEG decoded at reduced size)
    CameraProfile, DEFAULT_PROFILE, load_profile
    MIN_SIDE: fewest pixels across and high of an image the detector judges
    UndecodableImage: the ValueError of the two decoders for bytes that are not a whole
        JPEG/PNG image
"""

from .calibrate import calibrate
from .compare import Comparison, compare, compare_with_departure
from .confirm import ConfirmParams, confirm, detect_confirmed
from .detect import MIN_SIDE, WORK_SIDE, DetectionResult, Verdict, detect
from .overlay import overlay_png, recorded_result, render_overlay
from .profile import DEFAULT_PROFILE, CameraProfile, load_profile
from .regions import DiscCandidate
from .snapshot import UndecodableImage, decode_snapshot, detect_snapshot

__all__ = [
    "DEFAULT_PROFILE",
    "MIN_SIDE",
    "WORK_SIDE",
    "CameraProfile",
    "Comparison",
    "ConfirmParams",
    "DetectionResult",
    "DiscCandidate",
    "UndecodableImage",
    "Verdict",
    "calibrate",
    "compare",
    "compare_with_departure",
    "confirm",
    "decode_snapshot",
    "detect",
    "detect_confirmed",
    "detect_snapshot",
    "load_profile",
    "overlay_png",
    "recorded_result",
    "render_overlay",
]
