"""The learned Fea^m: a small fully convolutional network on the overhead depth image
(`fcn.py`), its data set of Drake-oracle labels (`dataset.py`), and its training
(`train_config.py`, `training.py`)."""
