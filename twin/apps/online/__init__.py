"""Online: the twin's online compensator (`twin.sim.online`) behind a robot's real-time interface.

Modules: `rsi` (KUKA RSI: XML over UDP, each `<Rob>` packet answered with `RKorr` and its `IPOC`).
"""
