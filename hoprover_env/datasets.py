"""`python -m hoprover_env.datasets`: the dataset builder's command line, at the path it
has always had. The module is `hoprover_env.evaluation.datasets`; importing this one
gives that module itself."""

import sys

from hoprover_env.evaluation import datasets as _datasets

if __name__ == "__main__":
    sys.exit(_datasets.main())
sys.modules[__name__] = _datasets
