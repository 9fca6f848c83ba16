"""Drawing the mouth beyond the paper's morph: learned coarticulation (``coarticulation``,
``learned``) and the trained face drawn from the person's own frames (``trained``); each
method with its fit."""
