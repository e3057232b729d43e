"""Effects outside the six causes: things a real lab adds that the diagnosis has no cause for.

They exist to make pairs of "a known cause plus an outside effect": the diagnosis should
still name the known cause and report the rest as unexplained. Neither changes the
transducer's physics; both act in the measurement chain (module ``dataset`` applies them to
the recorded channels).

* ``joint_backlash``: a loose joint between the rod's tip and the displacement sensor's
  target (a clamp or a push rod with clearance, the target held by friction): the target
  follows the tip only after the clearance 2 b is taken up, a play (backlash) operator
  y_s = max(y - b, min(y + b, y_s)) (Tao and Kokotovic, Adaptive Control of Systems with
  Actuator and Sensor Nonlinearities, 1996, ch. 1). It is applied to the displacement at the
  sample instants after the anti-alias filter (in this account the joint's kinks are not
  band-limited by it), the target at rest at the drive's switch-on; records that start
  after the transients see the play after one full period of motion (its periodic state).
  Rate independent, y only: the sense voltage is unchanged.
* ``mains_hum``: pickup of the 50 Hz mains and its third harmonic on the displacement and
  sense-voltage lines (ground loop, unshielded leads; e.g. Ott, Electromagnetic Compatibility
  Engineering, 2009, ch. 3), a random phase per run, through the anti-alias filter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

OUTSIDE_EFFECTS = ("joint_backlash", "mains_hum")


@dataclass(frozen=True)
class JointBacklash:
    """Play of half-width b between the rod's tip and the sensor's target."""

    half_width: float  # b: 0.3 um at strength 1, [m]

    @staticmethod
    def at(strength: float) -> "JointBacklash":
        # 0.3 um: a fit clearance of a few tenths of a micrometre in a clamped push rod
        return JointBacklash(0.3e-6 * strength)

    def apply(self, y: np.ndarray) -> np.ndarray:
        """The target's position for the tip's samples y (target at y[0] before), [m]."""
        b = self.half_width
        out = np.empty_like(y)
        z = y[0]
        for k, yk in enumerate(y):
            z = max(yk - b, min(yk + b, z))
            out[k] = z
        return out


@dataclass(frozen=True)
class MainsHum:
    """Mains pickup: amplitudes at 50 Hz on the displacement and sense-voltage channels,
    the third harmonic (150 Hz) at ``third`` of them."""

    displacement: float  # 0.15 um at strength 1, [m]
    voltage: float  # 2 mV at strength 1, [V]
    frequency: float = 50.0  # mains, [Hz]
    third: float = 0.3  # relative amplitude at 3 x the mains frequency, [-]

    @staticmethod
    def at(strength: float) -> "MainsHum":
        # 0.15 um (three times the default displacement noise) and 2 mV (four times the
        # sense-voltage noise): clearly visible in a spectrum, small beside the signals
        return MainsHum(0.15e-6 * strength, 2e-3 * strength)

    def signal(self, t: np.ndarray, phase: float, anti_alias, channel: str) -> np.ndarray:
        """The hum on a channel at times t after the anti-alias filter (exact for the
        steady sinusoids), [SI]."""
        amplitude = self.displacement if channel == "displacement" else self.voltage
        out = np.zeros(np.shape(t))
        for order, share in ((1, 1.0), (3, self.third)):
            w = 2.0 * math.pi * self.frequency * order
            gain = complex(anti_alias(1j * w))
            out += (share * amplitude * abs(gain)
                    * np.cos(w * np.asarray(t) + order * phase + np.angle(gain)))
        return out


FACTORIES = {"joint_backlash": JointBacklash.at, "mains_hum": MainsHum.at}
