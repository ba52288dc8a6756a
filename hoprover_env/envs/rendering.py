"""Frames of the rover: ground, target band, the rover to scale, its path, state, time.

Drawn with pygame on an off-screen Surface, so ``rgb_array`` needs no display;
``human`` blits the same Surface to a window. Nothing here runs unless an environment
was created with a render mode.
"""

from __future__ import annotations

import math
import os

import numpy as np

STATE_NAMES = {
    "A": "A flight",
    "B": "B pivot on A",
    "C": "C slide on A",
    "D": "D pivot on B",
    "E": "E slide on B",
    "F": "F at rest",
    "G": "G slide on both",
}
STATE_COLOURS = {
    "A": (70, 130, 220),
    "B": (230, 150, 40),
    "C": (220, 90, 40),
    "D": (230, 150, 40),
    "E": (220, 90, 40),
    "F": (60, 170, 90),
    "G": (150, 110, 200),
}


def _pygame():
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        # no screen (a server, CI): "human" draws into SDL's dummy video driver
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    try:
        import pygame
    except ImportError as exc:
        raise ImportError(
            "rendering needs pygame, in the render extra: pip install 'hoprover[render]'"
        ) from exc
    return pygame


class Renderer:
    """Draws rover states into frames of `width` x `height` pixels.

    `mode` "rgb_array" returns each frame as a (height, width, 3) uint8 array; "human"
    shows it in a pygame window at most `fps` frames per second instead. The view follows
    the rover, its recent path and the target band. Raises ImportError if pygame is
    missing.
    """

    def __init__(self, width: int = 640, height: int = 360, mode: str = "rgb_array", fps: int = 30):
        self.pg = _pygame()
        self.width, self.height, self.mode, self.fps = width, height, mode, fps
        self.pg.font.init()
        self.font = self.pg.font.Font(None, 20)
        self.surface = self.pg.Surface((width, height))
        self.window = None
        self.clock = None
        self.view = None  # (world x at the centre, world y on the ground row,
        # metres per pixel)

    def _fit_view(self, pts, ground_x, cos_phi, tan_phi):
        """A view that keeps the rover, its recent path and the target band in sight.

        `pts` are world points (x, y) [m] to keep in view, `ground_x` world x of ground
        points that must show (the target band's ends). The lowest of the points and of
        the ground under the view's ends sits on the ground row (0.88 of the height); on
        level ground that is y = 0, as it always was."""
        xs = [p[0] for p in pts]
        lo = min(min(xs), min(ground_x)) - 0.15 * cos_phi
        hi = max(max(xs), max(ground_x)) + 0.15 * cos_phi
        ends = (lo * tan_phi, hi * tan_phi)  # the ground's height at the ends
        bottom = min(min(p[1] for p in pts), *ends)
        top = max(max(p[1] for p in pts) + 0.15, max(ends) + 0.3)
        scale = max((hi - lo) / self.width, (top - bottom) / (0.8 * self.height))
        center = 0.5 * (lo + hi)
        if self.view is not None:  # move the camera smoothly, zoom out at once
            c0, b0, s0 = self.view
            scale = max(scale, 0.9 * s0 + 0.1 * scale)
            center = 0.8 * c0 + 0.2 * center
            bottom = 0.8 * b0 + 0.2 * bottom
        self.view = (center, bottom, scale)

    def draw(self, state, params, target, trace, t, letter, torque=0.0):
        """Draw one frame and return it ("rgb_array": (height, width, 3) uint8) or None
        ("human").

        Parameters: `state` = (x [m], y [m], theta [rad], ...) of the c.m. in the ground
        frame; `params` the RoverParams (size, band, slope); `target` [m] along the
        ground; `trace` the path so far, a list of ground-frame (x, y) [m]; `t` the time
        [s]; `letter` the contact state A-G; `torque` [N m].

        The picture is in the world frame, gravity pointing down: ground-frame points are
        turned by the slope phi (the ground rises toward +x for phi > 0), so the ground
        line, the rover and the target band on the ground are all inclined by phi.
        """
        pg = self.pg
        x, y, th = float(state[0]), float(state[1]), float(state[2])
        phi = float(getattr(params, "slope", 0.0))
        cp, sp = math.cos(phi), math.sin(phi)

        def world(gx, gy):
            # ground frame -> world frame: a rotation by phi (exact identity at phi = 0)
            return (gx * cp - gy * sp, gx * sp + gy * cp) if phi else (gx, gy)

        pts = trace[-400:] if trace else [(x, y)]
        w_band = params.band_half_width
        self._fit_view(
            [world(a, b) for a, b in pts] + [world(x, y)],
            [(target - w_band) * cp, (target + w_band) * cp],
            cp,
            sp / cp,
        )
        center, bottom, scale = self.view
        ground = int(self.height * 0.88)

        def px(gx, gy):
            wx, wy = world(gx, gy)
            return (
                int(round(self.width / 2 + (wx - center) / scale)),
                int(round(ground - (wy - bottom) / scale)),
            )

        surf = self.surface
        surf.fill((245, 245, 240))
        # the ground line from the left edge of the picture to the right one
        half = 0.5 * self.width * scale / cp + 1.0
        g0, g1 = px(center / cp - half, 0.0), px(center / cp + half, 0.0)
        pg.draw.polygon(
            surf, (200, 190, 170), [g0, g1, (g1[0], self.height + 10), (g0[0], self.height + 10)]
        )
        # the target band: a strip 8 px thick across the ground line, along it (on level
        # ground exactly the rectangle of pixels it always was)
        nx, ny = -sp, -cp  # the outward normal in pixels (rows down)
        a, b = px(target - w_band, 0.0), px(target + w_band, 0.0)
        b = (max(b[0], a[0] + 2) - 1, b[1])  # a band under 2 px still shows
        pg.draw.polygon(
            surf,
            (120, 200, 120),  # rounded: pygame would truncate
            [
                (round(p[0] + k * nx), round(p[1] + k * ny))
                for p, k in ((a, 4), (b, 4), (b, -3), (a, -3))
            ],
        )
        # the target: a mark along the ground's normal (positions are along the surface)
        pg.draw.line(surf, (40, 120, 40), px(target, 0), px(target, 0.25 * self.height * scale), 1)
        pg.draw.line(surf, (90, 80, 60), g0, g1, 2)
        if len(pts) > 1:
            pg.draw.lines(surf, (150, 170, 210), False, [px(a, b) for a, b in pts], 1)
        r, h = params.half_width, params.half_height
        c, s = math.cos(th), math.sin(th)
        corners = [
            (x + bx * c + by * s, y - bx * s + by * c)
            for bx, by in ((r, -h), (r, h), (-r, h), (-r, -h))
        ]
        colour = STATE_COLOURS.get(letter, (80, 80, 80))
        pg.draw.polygon(surf, colour, [px(*p) for p in corners])
        pg.draw.polygon(surf, (30, 30, 30), [px(*p) for p in corners], 1)
        # bottom corners A (right) and B (left), so that the contact state can be read
        pg.draw.circle(surf, (20, 20, 20), px(*corners[0]), 3)
        pg.draw.circle(surf, (255, 255, 255), px(*corners[3]), 3)
        lines = [
            f"t = {t:7.2f} s   state {STATE_NAMES.get(letter, letter)}",
            f"x = {x:+.3f} m   target {target:+.3f} m   T = {_torque_text(torque)} N m",
        ]
        if phi:
            lines.append(f"slope {phi:+.3f} rad ({math.degrees(phi):+.1f} deg), x along the ground")
        texts = [self.font.render(text, True, (20, 20, 20)) for text in lines]
        if phi:  # an inclined ground may run under the text: keep it readable
            box = pg.Surface((max(tx.get_width() for tx in texts) + 12, 18 * len(texts) + 6))
            box.fill((245, 245, 240))
            box.set_alpha(210)
            surf.blit(box, (2, 2))
        for i, tx in enumerate(texts):
            surf.blit(tx, (8, 6 + 18 * i))
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
