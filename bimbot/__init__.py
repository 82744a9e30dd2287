"""bimbot: IFC building models turned into robot construction simulations."""

__version__ = "0.1.0"
