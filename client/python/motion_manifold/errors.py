"""The one exception the client raises for a call the server refused or
could not answer, carrying the status and the request field at fault."""

import grpc

ERROR_FIELD_KEY = "mm-error-field"  # the trailing metadata naming the field (proto/README.md, "Errors")


class MotionManifoldError(Exception):
    """A refused or failed call.

    `code` is the gRPC status (grpc.StatusCode.INVALID_ARGUMENT, NOT_FOUND,
    UNAUTHENTICATED, UNAVAILABLE for a server that cannot be reached, ...),
    `status` its name ("INVALID_ARGUMENT"), `field` the request field the
    server names ("codes[0]", "frame_rate", "authorization"; "" when none is
    at fault) and `message` the server's message ("<field>: <what was found
    and what was expected>").
    """

    def __init__(self, code, field, message):
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.status = code.name
        self.field = field
        self.message = message

    @classmethod
    def from_rpc_error(cls, error):
        field = ""
        try:
            for key, value in error.trailing_metadata() or ():
                if key == ERROR_FIELD_KEY:
                    field = value
        except (AttributeError, ValueError):
            pass  # an error raised before any reply (no trailers)
        code = error.code() if callable(getattr(error, "code", None)) else grpc.StatusCode.UNKNOWN
        details = error.details() if callable(getattr(error, "details", None)) else str(error)
        return cls(code, field, details or "")
