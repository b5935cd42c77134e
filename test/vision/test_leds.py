import cv2
import numpy as np

from auv_dock_guidance.vision.leds import find_leds, glow_matches, glow_saturation, refined, water_colour


def _water(h=300, w=400):
    rng = np.random.default_rng(1)
    return np.clip(rng.normal(60, 2, (h, w, 3)), 0, 255).astype(np.float32)


def _bloom(image, u, v, halo=4.0, colour=(255, 110, 40)):
    yy, xx = np.mgrid[0:image.shape[0], 0:image.shape[1]]
    d2 = (xx - u) ** 2 + (yy - v) ** 2
    image += 2.5 * np.exp(-d2 / (2 * halo**2))[..., None] * np.array(colour, np.float32)
    image += 3.0 * 255 * np.exp(-d2 / (2 * 1.2**2))[..., None]
    return image


def _u8(image):
    return np.clip(image, 0, 255).astype(np.uint8)


def test_a_blooming_led_beside_a_saturated_disc_is_a_blob_at_its_centre():
    image = _water()
    cv2.circle(image, (150, 150), 60, (255, 255, 255), -1)
    image = _u8(_bloom(image, 228.0, 151.0))
    blobs = [refined(image, b) for b in find_leds(image, 1.0, 31)]
    near = [b for b in blobs if abs(b.u - 228) < 3 and abs(b.v - 151) < 3]
    assert near and abs(near[0].u - 228) < 1.0 and abs(near[0].v - 151) < 1.0


def test_a_cable_a_ring_fixture_and_texture_inside_a_lit_disc_are_not_isolated_lights():
    image = _water()
    cv2.line(image, (20, 10), (60, 290), (150, 150, 150), 2)
    cv2.circle(image, (270, 90), 45, (120, 120, 120), 3)
    cv2.circle(image, (260, 230), 50, (230, 230, 230), -1)
    cv2.circle(image, (260, 230), 3, (255, 255, 255), -1)  # a spot on the lit funnel
    blobs = [b for b in find_leds(_u8(cv2.GaussianBlur(image, (0, 0), 1.0)), 1.0, 31) if b.isolated]
    on_cable = [b for b in blobs if b.u < 70]
    on_fixture = [b for b in blobs if abs(np.hypot(b.u - 270, b.v - 90) - 45) < 6]
    inside_disc = [b for b in blobs if np.hypot(b.u - 260, b.v - 230) < 40]  # its rim may remain: no ring
    assert on_cable == [] and on_fixture == [] and inside_disc == []


def test_an_led_glows_in_its_colour_and_a_spot_it_lights_on_a_white_disc_glows_white():
    image = _water()
    cv2.circle(image, (150, 150), 60, (235, 240, 235), -1)  # the white funnel
    image = _bloom(image, 228.0, 151.0)  # a blue LED just outside it
    cv2.circle(image, (180, 104), 3, (255, 255, 255), -1)  # a bracket on the rim catching light
    image = _u8(image)
    water = water_colour(image)
    blobs = [refined(image, b, water) for b in find_leds(image, 1.0, 31)]
    led = next(b for b in blobs if abs(b.u - 228) < 3 and abs(b.v - 151) < 3)
    assert glow_saturation(led.glow_bgr) > 0.6
    spots = [b for b in blobs if abs(b.u - 180) < 4 and abs(b.v - 104) < 4]
    assert all(glow_saturation(b.glow_bgr) < 0.5 * glow_saturation(led.glow_bgr) for b in spots)


def test_a_given_colour_keeps_glows_of_its_hue_tinted_by_the_water_and_drops_others():
    blue = (1.0, 0.0, 0.0)
    assert glow_matches((166.0, 114.0, 14.0), blue)  # blue LEDs seen through green water: cyan-blue
    assert not glow_matches((20.0, 90.0, 180.0), blue)  # an orange lamp
    assert not glow_matches((150.0, 140.0, 135.0), blue)  # white light: no hue where the LEDs have one
    assert glow_matches((150.0, 140.0, 135.0), (1.0, 1.0, 1.0))  # white LEDs take any
    assert glow_matches(None, blue)  # not told (a grey image)


def _ring_in_one_glow(count=9, radius=32.0, centre=(200.0, 150.0)):
    """A distant ring whose LEDs bloom into one glow over a lit hub, as the far end of an approach shows it."""
    image = _water()
    cv2.circle(image, (int(centre[0]), int(centre[1])), int(radius - 6), (170, 175, 170), -1)
    image = cv2.GaussianBlur(image, (0, 0), 4.0)
    for k in range(count):
        a = 0.4 + 2.0 * np.pi * k / count
        _bloom(image, centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a), halo=6.0, colour=(50, 60, 50))
    return _u8(image)


def _on_ring(blobs, radius, centre=(200.0, 150.0)):
    return [b for b in blobs if abs(np.hypot(b.u - centre[0], b.v - centre[1]) - radius) < 4]


def test_blooming_leds_of_a_ring_stand_clear_beyond_their_halo():
    on_ring = _on_ring(find_leds(_ring_in_one_glow(radius=32.0), 1.0, 31), 32.0)
    assert len(on_ring) == 9
    assert all(b.isolated for b in on_ring)  # a circle beyond the halo is darker all round: each may seed


def test_leds_blooming_into_one_glow_are_found_though_none_stands_clear_of_it():
    on_ring = _on_ring(find_leds(_ring_in_one_glow(radius=18.0), 1.0, 31), 18.0)
    assert len(on_ring) == 9
    assert not any(b.isolated for b in on_ring)  # each sits in its neighbours' glow: they complete, not begin
