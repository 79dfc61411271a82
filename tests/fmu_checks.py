"""fmu-manipulation-toolbox's checks (what ``fmutool -input X.fmu -check`` runs), in process."""

import logging

from fmu_manipulation_toolbox.checker import get_checkers
from fmu_manipulation_toolbox.operations import FMU


class _Records(logging.Handler):
    def __init__(self):
        super().__init__(logging.INFO)
        self.records = []

    def emit(self, record):
        self.records.append((record.levelno, record.getMessage()))


def fmutool_check(path):
    """(errors, infos): the messages of fmutool's checkers on the FMU at ``path``."""
    handler, logger = _Records(), logging.getLogger("fmu_manipulation_toolbox")
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        fmu = FMU(str(path))
        with fmu:
            for checker in get_checkers():
                fmu.apply_operation(checker(), None)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
    errors = [message for levelno, message in handler.records if levelno >= logging.ERROR]
    infos = [message for levelno, message in handler.records if levelno < logging.ERROR]
    return errors, infos


def assert_fmutool_clean(path, fmi_version):
    """fmutool's generic (XSD) and semantic checks pass on ``path``, an FMI ``fmi_version``
    FMU, and say so."""
    errors, infos = fmutool_check(path)
    assert errors == [], (path, errors)
    assert f"This FMU seems to be compliant with FMI-{fmi_version}.0." in infos, infos
    assert f"No semantic error against the FMI-{fmi_version} standard." in infos, infos
