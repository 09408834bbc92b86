"""Caption grammar, colour words, crops and image loading."""

from __future__ import annotations

import numpy as np
import pytest
from llmland_vle.captions import caption_class, caption_vocabulary, colour_word, crop_caption, frame_caption
from llmland_vle.crops import ImageError, crop_square, encode_png, load_image, square_box
from llmland_vle.simcap.vocab import Vocab


def test_crop_captions() -> None:
    assert crop_caption("person", colour="red", surface="sidewalk", speed_mps=1.2, dynamic=True) == (
        "a person in a red shirt walking on the sidewalk")
    assert crop_caption("vehicle", colour="orange", surface="parking lot", size_m=(5.06, 1.95, 2.1)) == (
        "an orange van parked in a parking lot")
    assert crop_caption("vehicle", colour="blue", surface="road", speed_mps=5.0, dynamic=True,
                        size_m=(4.36, 1.8, 1.5)) == "a blue car driving on the road"
    assert crop_caption("building", colour="gray") == "a gray building"
    assert crop_caption("ground", surface="grass") == "a patch of grass"
    assert frame_caption("urban", ["tree", "person", "car", "car", "landing pad"]) == (
        "an aerial view of a street with a person, cars and a tree")
    assert frame_caption("open_field", []) == "an aerial view of a grass field"


def test_caption_class_and_vocabulary() -> None:
    assert caption_class("a person in a red shirt walking on the grass") == "person"
    assert caption_class("an orange van parked in a parking lot") == "vehicle"
    assert caption_class("a patch of grass") == "ground"
    assert caption_class("something else") is None
    vocab = Vocab(caption_vocabulary())
    text = "an aerial view of a street with a person, cars and a tree"
    assert vocab.decode(vocab.encode(text)) == text


@pytest.mark.parametrize(("rgb", "word"), [((240, 240, 240), "white"), ((20, 20, 20), "black"),
                                           ((128, 128, 128), "gray"), ((200, 30, 30), "red"),
                                           ((40, 150, 50), "green"), ((30, 60, 180), "blue"),
                                           ((240, 200, 30), "yellow"), ((110, 70, 40), "brown")])
def test_colour_words(rgb: tuple[int, int, int], word: str) -> None:
    assert colour_word(rgb) == word


def test_crops_and_images() -> None:
    img = np.zeros((100, 120, 3), np.uint8)
    img[40:60, 50:70] = 255
    crop = crop_square(img, (50, 40, 70, 60), 96)
    assert crop.shape == (96, 96, 3) and crop[48, 48].tolist() == [255, 255, 255]
    edge = crop_square(img, (110, 90, 120, 100), 32)  # past the border: edge pixels replicated
    assert edge.shape == (32, 32, 3)
    su, sv, eu, ev = square_box((0, 0, 10, 30))
    assert eu - su == ev - sv >= 30
    assert np.array_equal(load_image(encode_png(img)), img)
    for bad in (b"", b"GIF89a....", b"\x89PNG\r\n\x1a\n truncated"):
        with pytest.raises(ImageError):
            load_image(bad)
