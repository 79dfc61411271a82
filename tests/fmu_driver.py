"""Drive one FMU directly through fmpy, collecting statuses and log messages (FMI 2.0 through
the master's LogBook, FMI 3.0 through fmpy's FMU3Slave and a callback of its own)."""

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

from mechfmu.cosim.master import LogBook, accessor


class _Fmi3Log:
    """FMI 3.0 log messages, in the LogBook's form (FMI 3 passes no instance name)."""

    def __init__(self, instance):
        self.instance, self.messages = instance, []

    def __call__(self, environment, status, category, message):
        self.messages.append(
            {
                "instance": self.instance,
                "status": status,
                "category": category.decode(),
                "message": message.decode(),
            }
        )

    def last_problem(self, instance):
        problems = [m["message"] for m in self.messages if m["status"] > 1]
        return problems[-1] if problems else ""


class Driven:
    """An instantiated, initialised FMU (FMI 2.0 or 3.0); ``step`` returns True or the error
    text."""

    def __init__(self, path, parameters=None, inputs=None, start_time=0.0, instance="under_test"):
        self.description = read_model_description(str(path))
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.folder = extract(str(path))
        options = dict(
            guid=self.description.guid,
            unzipDirectory=self.folder,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=instance,
        )
        if self.description.fmiVersion.startswith("3"):
            self.logbook = _Fmi3Log(instance)
            self.slave = FMU3Slave(**options)
            self.slave.instantiate(loggingOn=True, logMessage=self.logbook)
            self.slave.enterInitializationMode(startTime=start_time)
        else:
            self.logbook = LogBook()
            self.slave = FMU2Slave(**options)
            self.slave.instantiate(callbacks=self.logbook.callbacks, loggingOn=True)
            self.slave.setupExperiment(startTime=start_time)
            self.slave.enterInitializationMode()
        self.instance = instance
        self.set(**(parameters or {}))
        self.set(**(inputs or {}))
        self.init_error = None  # the FMU's message when it refused to leave initialisation
        try:
            self.slave.exitInitializationMode()
        except FMICallException as error:
            self.init_error = f"{self.logbook.last_problem(instance)} [{error}]"
        self.time = start_time

    def set(self, **values):
        for name, value in values.items():
            variable = self.variables[name]
            accessor(self.slave, variable.type, "set")([variable.valueReference], [value])

    def get(self, name):
        variable = self.variables[name]
        return accessor(self.slave, variable.type, "get")([variable.valueReference])[0]

    def outputs(self):
        """Every Real (Float64) output, in declaration order."""
        return [
            self.get(v.name)
            for v in self.description.modelVariables
            if v.causality == "output" and v.type in ("Real", "Float64")
        ]

    def step(self, size, **inputs):
        """Set inputs, do one step; True on success, else the FMU's last error message."""
        self.set(**inputs)
        try:
            self.slave.doStep(currentCommunicationPoint=self.time, communicationStepSize=size)
        except FMICallException as error:
            return f"{self.logbook.last_problem(self.instance)} [{error}]"
        self.time += size
        return True

    def replayed(self, run):
        """``run()`` twice from one FMU state (FMI 2.0: the state and the time restored in
        between): (its first result, its second)."""
        state, saved_time = self.slave.getFMUstate(), self.time
        try:
            first = run()
            self.slave.setFMUstate(state)
            self.time = saved_time
            return first, run()
        finally:
            self.slave.freeFMUstate(state)

    def messages(self, status=None):
        return [
            m["message"] for m in self.logbook.messages if status is None or m["status"] == status
        ]

    def close(self):
        try:
            self.slave.terminate()
        except FMICallException:
            pass  # not allowed in every state (error, instantiated): freeing is
        finally:
            self.slave.freeInstance()
