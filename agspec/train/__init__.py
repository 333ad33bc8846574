"""Training the paper's MARL references: IPPO, MAPPO and QMIX exactly as tab:marlconfig gives them
(spec/16-training.md).  The stable entry points are in :mod:`agspec.train.api`; PyTorch is the
optional extra ``agspec[train]`` and is imported only by the modules that train or load a network.
"""
