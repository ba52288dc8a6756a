"""Frames of the rover: ground, target band, the rover to scale, its path, state, time.

Drawn with pygame on an off-screen Surface, so ``rgb_array`` needs no display;
``human`` blits the same Surface to a window. Nothing here runs unless an environment
was created with a render mode.
"""
from __future__ import annotations

import math
import os

import numpy as np

STATE_NAMES = {"A": "A flight", "B": "B pivot on A", "C": "C slide on A", "D": "D pivot on B",
               "E": "E slide on B", "F": "F at rest", "G": "G slide on both"}
STATE_COLOURS = {"A": (70, 130, 220), "B": (230, 150, 40), "C": (220, 90, 40),
                 "D": (230, 150, 40), "E": (220, 90, 40), "F": (60, 170, 90),
                 "G": (150, 110, 200)}


def _pygame():
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        # no screen (a server, CI): "human" draws into SDL's dummy video driver
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    try:
        import pygame
    except ImportError as exc:  # pragma: no cover - pygame is a dependency of the package
        raise ImportError("rendering needs pygame: pip install pygame") from exc
    return pygame


class Renderer:
    """Draws rover states into frames of `width` x `height` pixels.

    `mode` "rgb_array" returns each frame as a (height, width, 3) uint8 array; "human"
    shows it in a pygame window at most `fps` frames per second instead. The view follows
    the rover, its recent path and the target band. Raises ImportError if pygame is
    missing.
    """

    def __init__(self, width: int = 640, height: int = 360, mode: str = "rgb_array",
                 fps: int = 30):
        self.pg = _pygame()
        self.width, self.height, self.mode, self.fps = width, height, mode, fps
        self.pg.font.init()
        self.font = self.pg.font.Font(None, 20)
        self.surface = self.pg.Surface((width, height))
        self.window = None
        self.clock = None
        self.view = None        # (x_center, metres per pixel)

    def _fit_view(self, xs, ys, target, half_width):
        """A view that keeps the rover, its recent path and the target band in sight."""
        lo = min(min(xs), target - half_width) - 0.15
        hi = max(max(xs), target + half_width) + 0.15
        top = max(max(ys) + 0.15, 0.3)
        scale = max((hi - lo) / self.width, top / (0.8 * self.height))
        center = 0.5 * (lo + hi)
        if self.view is not None:         # move the camera smoothly, zoom out at once
            c0, s0 = self.view
            scale = max(scale, 0.9 * s0 + 0.1 * scale)
            center = 0.8 * c0 + 0.2 * center
        self.view = (center, scale)

    def draw(self, state, params, target, trace, t, letter, torque=0.0):
        """Draw one frame and return it ("rgb_array": (height, width, 3) uint8) or None
        ("human").

        Parameters: `state` = (x [m], y [m], theta [rad], ...) of the c.m.; `params` the
        RoverParams (size, band); `target` [m]; `trace` the path so far, a list of (x, y)
        [m]; `t` the time [s]; `letter` the contact state A-G; `torque` [N m].
        """
        pg = self.pg
        x, y, th = float(state[0]), float(state[1]), float(state[2])
        pts = trace[-400:] if trace else [(x, y)]
        self._fit_view([p[0] for p in pts] + [x], [p[1] for p in pts] + [y], target,
                       params.band_half_width)
        center, scale = self.view
        ground = int(self.height * 0.88)

        def px(wx, wy):
            return (int(round(self.width / 2 + (wx - center) / scale)),
                    int(round(ground - wy / scale)))

        surf = self.surface
        surf.fill((245, 245, 240))
        pg.draw.rect(surf, (200, 190, 170), (0, ground, self.width, self.height - ground))
        left, _ = px(target - params.band_half_width, 0)
        right, _ = px(target + params.band_half_width, 0)
        band = pg.Rect(left, ground - 4, max(right - left, 2), 8)
        pg.draw.rect(surf, (120, 200, 120), band)
        pg.draw.line(surf, (40, 120, 40), px(target, 0), px(target, 0.25 * self.height * scale), 1)
        pg.draw.line(surf, (90, 80, 60), (0, ground), (self.width, ground), 2)
        if len(pts) > 1:
            pg.draw.lines(surf, (150, 170, 210), False, [px(a, b) for a, b in pts], 1)
        r, h = params.half_width, params.half_height
        c, s = math.cos(th), math.sin(th)
        corners = [(x + bx * c + by * s, y - bx * s + by * c)
                   for bx, by in ((r, -h), (r, h), (-r, h), (-r, -h))]
        colour = STATE_COLOURS.get(letter, (80, 80, 80))
        pg.draw.polygon(surf, colour, [px(*p) for p in corners])
        pg.draw.polygon(surf, (30, 30, 30), [px(*p) for p in corners], 1)
        # bottom corners A (right) and B (left), so that the contact state can be read
        pg.draw.circle(surf, (20, 20, 20), px(*corners[0]), 3)
        pg.draw.circle(surf, (255, 255, 255), px(*corners[3]), 3)
        lines = [f"t = {t:7.2f} s   state {STATE_NAMES.get(letter, letter)}",
                 f"x = {x:+.3f} m   target {target:+.3f} m   T = {_torque_text(torque)} N m"]
        for i, text in enumerate(lines):
            surf.blit(self.font.render(text, True, (20, 20, 20)), (8, 6 + 18 * i))
        if self.mode == "human":
            self._show()
            return None
        return np.ascontiguousarray(np.transpose(pg.surfarray.array3d(surf), (1, 0, 2)))

    def _show(self):
        pg = self.pg
        if self.window is None:
            pg.display.init()
            self.window = pg.display.set_mode((self.width, self.height))
            pg.display.set_caption("hoprover")
            self.clock = pg.time.Clock()
        pg.event.pump()
        self.window.blit(self.surface, (0, 0))
        pg.display.flip()
        self.clock.tick(self.fps)

    def close(self):
        """Close the window, if one was opened (mode "human")."""
        if self.window is not None:
            self.pg.display.quit()
            self.window = None


def _torque_text(torque: float) -> str:
    """'+3.00e-4', and '0' rather than '-0.00e-4' for a torque that rounds to nothing."""
    text = f"{torque * 1e4:+.2f}"
    return "0" if float(text) == 0.0 else f"{text}e-4"
