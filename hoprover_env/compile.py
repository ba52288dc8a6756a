"""`python -m hoprover_env.compile`: warm numba's on-disk cache, at the path it has
always had. The module is `hoprover_env.training.warm_cache`; importing this one gives
that module itself."""

import sys

from hoprover_env.training import warm_cache as _warm_cache

if __name__ == "__main__":
    sys.exit(_warm_cache.main())
sys.modules[__name__] = _warm_cache
