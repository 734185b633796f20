"""morphology.dilate_disk / dilate_rows against cv2.dilate with the same kernel."""

import cv2
import numpy as np
import pytest

from frontier_detector import morphology
from frontier_detector.morphology import dilate_disk, dilate_rows, disk_kernel


@pytest.mark.parametrize("strip_cells", [720_000, 200, 1])
@pytest.mark.parametrize("radius", [0.0, 0.5, 1.0, 1.5, 2.5, 6.0 - 1e-6, 7.3, 12.0])
def test_dilate_disk_equals_cv2_dilate(radius, strip_cells, monkeypatch):
    monkeypatch.setattr(morphology, "STRIP_CELLS", strip_cells)
    rng = np.random.default_rng(int(radius * 10) + strip_cells)
    for shape in [(1, 1), (1, 9), (9, 1), (40, 3), (61, 70)]:
        for density in (0.01, 0.3):
            m = ((rng.random(shape) < density) * 255).astype(np.uint8)
            ref = cv2.dilate(m, disk_kernel(radius), borderType=cv2.BORDER_CONSTANT,
                             borderValue=0)
            got = dilate_disk(m, radius)
            assert got.dtype == np.uint8 and np.array_equal(got, ref), (radius, shape)


@pytest.mark.parametrize("half", [[0, 0, 0], [3], [2, 2], [4, 4, 2, 1], [1, 0]])
def test_dilate_rows_equals_cv2_dilate_with_that_kernel(half, monkeypatch):
    monkeypatch.setattr(morphology, "STRIP_CELLS", 5 * 31)
    r, w = len(half) - 1, half[0]
    kernel = np.zeros((2 * r + 1, 2 * w + 1), np.uint8)
    for dy, hw in enumerate(half):
        kernel[r + dy, w - hw: w + hw + 1] = 1
        kernel[r - dy, w - hw: w + hw + 1] = 1
    m = ((np.random.default_rng(len(half)).random((23, 31)) < 0.05) * 255).astype(np.uint8)
    ref = cv2.dilate(m, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    assert np.array_equal(dilate_rows(m, half), ref)


def test_dilate_rows_rejects_a_kernel_wider_away_from_the_middle():
    with pytest.raises(ValueError):
        dilate_rows(np.zeros((3, 3), np.uint8), [1, 2])


@pytest.mark.parametrize("radius", [0.0, 1.5, 6.0 - 1e-6])
def test_dilate_disk_stack_equals_cv2_dilate_of_each_image_away_from_its_border(radius):
    from frontier_detector.morphology import dilate_disk_stack
    rng = np.random.default_rng(int(radius * 10))
    m = int(np.ceil(radius))                      # cells next to another image may differ
    for n, side in [(1, 5), (3, 17), (40, 23)]:
        stack = ((rng.random((n, side, side)) < 0.05) * 255).astype(np.uint8)
        got = dilate_disk_stack(stack, radius)
        assert got.shape == stack.shape and got.dtype == np.uint8
        for i in range(n):
            ref = cv2.dilate(stack[i], disk_kernel(radius), borderType=cv2.BORDER_CONSTANT,
                             borderValue=0)
            inner = (slice(m, side - m),) * 2
            assert np.array_equal(got[i][inner], ref[inner]), (n, side, i)
    one = np.zeros((1, 9, 9), np.uint8)
    one[0, 4, 4] = 1
    assert np.array_equal(dilate_disk_stack(one, 2.0)[0],
                          cv2.dilate(one[0], disk_kernel(2.0)))   # a single image: all of it


@pytest.mark.parametrize("radius", [0.0, 0.5, 1.0, 2.5, 6.0 - 1e-6, 7.3])
def test_clear_of_equals_keep_minus_cv2_dilated_obstacles(radius):
    """The compiled sweep against OpenCV, on whole images and on windows of a larger one
    (rows not contiguous with each other), including images thinner than the disc."""
    from frontier_detector.morphology import clear_of
    rng = np.random.default_rng(int(radius * 10))
    big = rng.choice(np.array([0, 100, -1], np.int8), size=(90, 97), p=[0.7, 0.05, 0.25])
    for image in (big, big[5:66, 3:80], big[:1, :], big[:, 10:11], big[40:43, 2:6]):
        u8 = image.view(np.uint8)
        dilated = cv2.dilate((u8 == 100).astype(np.uint8), disk_kernel(radius),
                             borderType=cv2.BORDER_CONSTANT, borderValue=0)
        ref = ((u8 == 0) & (dilated == 0)).astype(np.uint8) * 255
        got = clear_of(image, 0, 100, radius)
        assert got.dtype == np.uint8 and np.array_equal(got, ref), (radius, image.shape)
