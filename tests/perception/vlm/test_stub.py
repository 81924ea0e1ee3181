"""The colour-and-shape stub client (`client: stub`): reads a label as a colour and a shape, and answers like a
remote VLM — points normalised to 0–1000, latency, misses and noise."""

from __future__ import annotations

import numpy as np
import pytest

from mission.core import se3
from mission.perception_plugins.vlm.client import VlmPoint
from mission.perception_plugins.vlm.stub import ColourShapeClient, ObjectQuery, parse_label
from tests.helpers.vlm_scene import Ball, Box, Scene, box_front_face, camera_pose, render

RED = (30, 30, 200)  # BGR
BLUE = (200, 60, 30)


@pytest.fixture(scope="module")
def red_box_and_blue_ball():
    box = Box((3.0, 0.3, 0.25), (0.3, 0.3, 0.5), RED)
    ball = Ball((2.5, -0.5, 0.2), 0.2, BLUE)
    cam = camera_pose(0.0, 0.0, 0.0)
    return render(Scene([box], [ball]), cam), box, ball, cam


@pytest.mark.parametrize(
    ("label", "expected"),
    [
        ("red box", ObjectQuery("red", "box")),
        ("the big Red Cube", ObjectQuery("red", "box")),
        ("blue ball", ObjectQuery("blue", "round")),
        ("green bottle", ObjectQuery("green", None)),
        ("grey crate", ObjectQuery("grey", "box")),
        ("gray sphere", ObjectQuery("grey", "round")),
        ("trash bag", ObjectQuery(None, None)),
    ],
)
def test_a_label_is_read_as_a_colour_and_an_optional_shape(label, expected):
    assert parse_label(label) == expected


def test_the_stub_answers_like_a_vlm_with_points_normalised_to_0_1000(red_box_and_blue_ball):
    frame, box, _, cam = red_box_and_blue_ball
    points = ColourShapeClient().locate(frame.image, "red box")
    assert points and all(isinstance(p, VlmPoint) for p in points)
    best = points[0]
    assert 0 <= best.y <= 1000 and 0 <= best.x <= 1000 and 0.5 <= best.confidence <= 1.0
    u, v = best.to_pixel(frame.width, frame.height)
    face_centre = se3.apply(se3.invert(cam), box_front_face(box)[:3, 3])
    expected = frame.intrinsics.project(face_centre)[0]
    assert np.hypot(u - expected[0], v - expected[1]) < 4.0  # within a few px of the face centre


def test_the_stub_finds_each_object_by_its_colour(red_box_and_blue_ball):
    frame, _, ball, cam = red_box_and_blue_ball
    points = ColourShapeClient().locate(frame.image, "blue ball")
    u, v = points[0].to_pixel(frame.width, frame.height)
    expected = frame.intrinsics.project(se3.apply(se3.invert(cam), np.asarray(ball.centre)))[0]
    assert np.hypot(u - expected[0], v - expected[1]) < 4.0
    assert ColourShapeClient().locate(frame.image, "green cube") == []


def test_the_shape_word_picks_between_objects_of_the_same_colour():
    box = Box((3.0, 0.4, 0.25), (0.3, 0.3, 0.5), RED)
    ball = Ball((3.0, -0.5, 0.25), 0.22, RED)
    cam = camera_pose(0.0, 0.0, 0.0)
    frame = render(Scene([box], [ball]), cam)
    client = ColourShapeClient()

    def nearest(label):
        u, v = client.locate(frame.image, label)[0].to_pixel(frame.width, frame.height)
        ball_px = frame.intrinsics.project(se3.apply(se3.invert(cam), np.asarray(ball.centre)))[0]
        box_px = frame.intrinsics.project(se3.apply(se3.invert(cam), box_front_face(box)[:3, 3]))[0]
        return "ball" if np.hypot(*(ball_px - (u, v))) < np.hypot(*(box_px - (u, v))) else "box"

    assert nearest("red ball") == "ball"
    assert nearest("red box") == "box"


def test_misses_and_pixel_noise_are_seeded_so_runs_repeat(red_box_and_blue_ball):
    frame = red_box_and_blue_ball[0]

    def answers(seed):
        client = ColourShapeClient(miss_rate=0.3, pixel_noise=3.0, seed=seed)
        return [tuple((p.y, p.x) for p in client.locate(frame.image, "red box")[:1]) for _ in range(20)]

    first = answers(seed=4)
    assert first == answers(seed=4)
    assert first != answers(seed=5)
    misses = sum(1 for a in first if not a)
    assert 1 <= misses <= 12  # occasional, not never and not always
    assert len({a for a in first if a}) > 1  # noisy pixels differ from call to call


def test_a_model_that_always_misses_returns_no_points(red_box_and_blue_ball):
    assert ColourShapeClient(miss_rate=1.0).locate(red_box_and_blue_ball[0].image, "red box") == []


def test_a_mono_image_has_no_colour_to_find(red_box_and_blue_ball):
    gray = red_box_and_blue_ball[0].image[:, :, 1].copy()
    assert ColourShapeClient().locate(gray, "red box") == []


def test_close_interrupts_a_call_waiting_on_latency(red_box_and_blue_ball):
    client = ColourShapeClient(latency_s=60.0)
    client.close()  # a closed client answers at once instead of waiting for the "server"
    assert client.locate(red_box_and_blue_ball[0].image, "red box") == []
