"""The paper's second method (§4): the keypoint CNN and its refiner (`estimator`, registry
name ``cnn``) and its PCP scoring beside the paper's tables (`report`)."""
