"""The views stage, the public xarray views of one evaluation: the time domain
(:func:`harmbal.simulate`), the order spectrum (:func:`harmbal.order_spectrum`)
and the crank stars (:func:`harmbal.stars`)."""
