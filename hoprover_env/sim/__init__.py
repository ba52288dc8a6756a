"""The simulation API over the physics kernel: `simulate` (one run, any controller),
`simulate_batch` (N runs in one threaded call), the compiled run loop (`rollout`),
shared control laws (`controllers`), an independent scipy reference of the contact
phases (`reference`) and invariant checks of a state (`testing`)."""
