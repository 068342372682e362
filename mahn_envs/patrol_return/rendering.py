"""Drawing the task with pygame: walls, POIs, home, robots with heading and IR rays, who has the signal.

Off-screen surfaces for "rgb_array" (no display needed), a window only in "human" mode, as PettingZoo's
pymunk envs do.
"""
from __future__ import annotations

import math
import os

import numpy as np

from ..maps import World

ROBOT_COLOURS = [(66, 133, 244), (219, 68, 55), (15, 157, 88), (244, 160, 0), (171, 71, 188), (0, 172, 193)]
SIGNAL_COLOUR = (255, 200, 0)


class Renderer:
    """Turns (poses, rays, signals) into pictures of a World."""

    def __init__(self, world: World, mode: str, size_px: int = 560, fps: int = 30) -> None:
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        import pygame

        self.pygame = pygame
        self.world = world
        self.mode = mode
        self.fps = fps
        xmin, ymin, xmax, ymax = world.bounds
        margin = 8.0
        self.xmin, self.ymax = xmin - margin, ymax + margin
        span = max(xmax - xmin, ymax - ymin) + 2 * margin
        self.scale = size_px / span
        self.w = int(round((xmax - xmin + 2 * margin) * self.scale))
        self.h = int(round((ymax - ymin + 2 * margin) * self.scale))
        if mode == "human":
            pygame.init()
        else:  # off-screen drawing needs no display (works headless without SDL_VIDEODRIVER tricks)
            pygame.font.init()
        self.window: pygame.Surface | None = None
        self.clock = None
        if mode == "human":
            self.window = pygame.display.set_mode((self.w, self.h))
            pygame.display.set_caption(f"mahn patrol_return: {world.name}")
            self.clock = pygame.time.Clock()
        self.surface = pygame.Surface((self.w, self.h))
        self.font = pygame.font.Font(None, 18)

    def to_px(self, x: float, y: float) -> tuple[int, int]:
        return int(round((x - self.xmin) * self.scale)), int(round((self.ymax - y) * self.scale))

    def draw(self, poses: np.ndarray, rays: np.ndarray | None, signals: np.ndarray, angles: np.ndarray,
             radius: float, tick: int, fitness: float) -> None:
        pg = self.pygame
        s = self.surface
        s.fill((250, 250, 248))
        for x1, y1, x2, y2 in self.world.walls:
            pg.draw.line(s, (40, 40, 40), self.to_px(x1, y1), self.to_px(x2, y2), max(2, int(self.scale)))
        hx, hy = self.world.home
        pg.draw.circle(s, (120, 120, 120), self.to_px(hx, hy), int(20 * self.scale), 1)
        label = self.font.render("home", True, (90, 90, 90))
        s.blit(label, self.to_px(hx + 3, hy + 3))
        for p, (px, py) in enumerate(self.world.pois):
            c = self.to_px(px, py)
            pg.draw.circle(s, (150, 150, 150), c, int(10 * self.scale), 1)
            pg.draw.line(s, (150, 150, 150), (c[0] - 4, c[1]), (c[0] + 4, c[1]))
            pg.draw.line(s, (150, 150, 150), (c[0], c[1] - 4), (c[0], c[1] + 4))
            s.blit(self.font.render(f"P{p}", True, (120, 120, 120)), (c[0] + 5, c[1] + 5))
        for r, (x, y, h) in enumerate(poses):
            colour = ROBOT_COLOURS[r % len(ROBOT_COLOURS)]
            if rays is not None:
                for j, a in enumerate(angles):
                    d = rays[r, j]
                    end = (x + math.cos(h + a) * d, y + math.sin(h + a) * d)
                    pg.draw.line(s, (200, 200, 210), self.to_px(x, y), self.to_px(*end), 1)
            c = self.to_px(x, y)
            if signals[r]:
                pg.draw.circle(s, SIGNAL_COLOUR, c, int((radius + 2.5) * self.scale))
            pg.draw.circle(s, colour, c, int(radius * self.scale))
            tip = self.to_px(x + math.cos(h) * radius, y + math.sin(h) * radius)
            pg.draw.line(s, (255, 255, 255), c, tip, 2)
            s.blit(self.font.render(str(r), True, (0, 0, 0)), (c[0] + int(radius * self.scale), c[1]))
        text = f"t={tick}  fitness={fitness:.2f}  signal={'on' if np.any(signals) else 'off'}"
        s.blit(self.font.render(text, True, (0, 0, 0)), (6, 6))

    def rgb(self) -> np.ndarray:
        return np.transpose(self.pygame.surfarray.array3d(self.surface), (1, 0, 2)).astype(np.uint8).copy()

    def show(self) -> None:
        if self.window is None or self.clock is None:
            return
        self.pygame.event.pump()
        self.window.blit(self.surface, (0, 0))
        self.pygame.display.flip()
        self.clock.tick(self.fps)

    def close(self) -> None:
        if self.window is not None:
            self.pygame.display.quit()
            self.window = None


def render_env(env, poses: np.ndarray, rays: np.ndarray | None, signals: np.ndarray, tick: int,
               fitness: float):
    """The `render()` of every env of the task (simulated or hardware): one picture, one code path.

    `env` needs `render_mode`, `world`, `model`, `metadata` and a `_renderer` slot (created on first use).
    """
    if env.render_mode is None:
        import gymnasium

        gymnasium.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
        return None
    if env._renderer is None:
        env._renderer = Renderer(env.world, env.render_mode, fps=env.metadata["render_fps"])
    env._renderer.draw(poses, rays, signals, np.asarray(env.model.sensor_angles), env.model.radius, tick, fitness)
    if env.render_mode == "rgb_array":
        return env._renderer.rgb()
    env._renderer.show()
    return None
